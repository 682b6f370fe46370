//! The fields at a fixed shape: the fractions φ that minimise the species'
//! free energy ([`crate::species::free_energy`]) with every conserved
//! species' protein count N_s = Σ_i A_i φ_s,i / a_s held exactly and every
//! bulk species exchanging proteins at its chemical potential μ_s, that is
//! the minimum of the grand potential Ω = F − Σ_{bulk s} μ_s N_s.
//!
//! Newton's method on per-vertex blocks: each vertex's S×S Hessian of the
//! local free energy (entropy, interactions, coupled bending) plus the
//! diagonal of the gradient energies, factorised by a dense Cholesky
//! (shifted where the local energy is not convex: a demixing χ); the counts
//! enter as multipliers λ_c, found each step from a |C|×|C| system so that
//! Σ_i w_i δφ_c,i = 0 exactly. Steps stay a fraction of the way to the
//! bounds φ > 0, Σφ < 1 and decrease Ω (Armijo backtracking). Without
//! gradient energies the blocks are the exact Hessian and the convergence
//! is quadratic. At the end λ_c is the conserved species' chemical
//! potential (Ē per protein), and every vertex satisfies a_s ∂f/∂φ_s = μ_s
//! (for one species the Fermi-Dirac relation
//! φ_i = 1/(1 + e^{(ε_i − μ)/k_BT}), ε_i = −a_p κ c (h_i − c φ_i)).

use crate::energy::bending_measure::{Surface, VertexTerms};
use crate::species::free_energy::{BaseBending, Evaluated, LocalEnergy, LocalValues};
use crate::species::measured::{Block, HessianConstants, MeasuredVertices};
use crate::species::params::{MAX_SPECIES, Reservoir, SpeciesSet};

/// When the relaxation stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelaxSettings {
    /// The largest residual a_s-free chemical-potential imbalance per area
    /// |∂F/∂φ_s,i − μ_s A_i/a_s| / A_i (Ē/l̄²) accepted.
    pub tolerance: f64,
    /// The most Newton steps.
    pub max_iterations: usize,
}

/// What the relaxation reached.
#[derive(Clone, Debug, PartialEq)]
pub struct Relaxed {
    /// Newton steps taken.
    pub iterations: usize,
    /// The residual (Ē/l̄², as [`RelaxSettings::tolerance`]) at the end.
    pub residual: f64,
    /// Each species' chemical potential μ_s (Ē per protein): the
    /// multiplier of a conserved species' count, the bulk's for the others.
    pub chemical_potentials: Vec<f64>,
    /// The grand potential Ω at the end (Ē).
    pub grand_potential: f64,
    /// Vertices whose start [`relax_amounts`] brought back inside the
    /// fields' domain (a remesh event had squeezed their cells under their
    /// proteins).
    pub repaired: usize,
}

/// Why the relaxation failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RelaxError {
    /// A field starts outside φ > 0, Σφ < 1.
    #[error(
        "species {species}: φ = {value} at vertex {vertex} is outside (0, 1) or the fractions sum to 1 or more"
    )]
    Outside {
        /// The species' index.
        species: usize,
        /// The dense vertex slot.
        vertex: usize,
        /// The value found.
        value: f64,
    },
    /// No step lowered the grand potential before the residual reached the
    /// tolerance, or the step cap came first.
    #[error(
        "the fields did not relax: residual {residual:e} Ē/l̄² after {iterations} Newton steps (tolerance {tolerance:e})"
    )]
    NotConverged {
        /// Steps taken.
        iterations: usize,
        /// The residual reached.
        residual: f64,
        /// The tolerance asked for.
        tolerance: f64,
    },
}

/// Fraction of the distance to a bound a step may go.
const TO_BOUNDARY: f64 = 0.9;

/// Largest relative change of any fraction (or of the solvent's) for which
/// a Newton step is taken in full without measuring the grand potential at
/// its end.
const QUADRATIC_REGIME: f64 = 1e-2;

/// The lower Cholesky factor of `a` (S×S) in place; false if `a` is not
/// positive definite.
#[inline]
fn cholesky(a: &mut Block, s: usize) -> bool {
    for j in 0..s {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k];
        }
        if d <= 0.0 || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j][j] = d;
        for i in j + 1..s {
            let mut x = a[i][j];
            for k in 0..j {
                x -= a[i][k] * a[j][k];
            }
            a[i][j] = x / d;
        }
    }
    true
}

/// Solves L Lᵀ x = b in place with the factor of [`cholesky`] (of
/// [`factorise`] for one species: the inverse).
#[inline]
fn cholesky_solve(l: &Block, s: usize, b: &mut [f64]) {
    if s == 1 {
        b[0] *= l[0][0];
        return;
    }
    for i in 0..s {
        let mut x = b[i];
        for k in 0..i {
            x -= l[i][k] * b[k];
        }
        b[i] = x / l[i][i];
    }
    for i in (0..s).rev() {
        let mut x = b[i];
        for k in i + 1..s {
            x -= l[k][i] * b[k];
        }
        b[i] = x / l[i][i];
    }
}

/// Factorises the symmetric `h` (S×S) in place into its lower Cholesky
/// factor, shifting its diagonal where it is not positive definite. Only
/// the lower triangle is overwritten, so a failed attempt is undone from
/// the upper one and the saved diagonal.
#[inline]
fn factorise(h: &mut Block, s: usize) {
    // One species: the 1×1 "factor" is the block's inverse, which
    // [`cholesky_solve`] multiplies by.
    if s == 1 && h[0][0] > 0.0 && h[0][0].is_finite() {
        h[0][0] = 1.0 / h[0][0];
        return;
    }
    let mut diagonal = [0.0; MAX_SPECIES];
    for k in 0..s {
        diagonal[k] = h[k][k];
    }
    let scale = diagonal[..s]
        .iter()
        .map(|d| d.abs())
        .fold(0.0, f64::max)
        .max(1e-300);
    let mut shift = 0.0;
    while !cholesky(h, s) {
        shift = if shift == 0.0 {
            1e-10 * scale
        } else {
            shift * 10.0
        };
        if !shift.is_finite() {
            // A non-finite block (the step it gives is refused as NaN).
            for i in 0..s {
                h[i][..s].fill(f64::NAN);
            }
            return;
        }
        for i in 0..s {
            for j in 0..i {
                h[i][j] = h[j][i];
            }
            h[i][i] = diagonal[i] + shift;
        }
    }
    if s == 1 {
        h[0][0] = 1.0 / (h[0][0] * h[0][0]);
    }
}

/// Relaxes the fractions `phi` (by species, then dense slot) on `shape` to
/// the minimum of the grand potential, holding every conserved species'
/// count. `phi` must be inside the bounds.
pub fn relax_fields(
    shape: Surface<'_>,
    base: BaseBending,
    set: &SpeciesSet,
    phi: &mut [Vec<f64>],
    settings: RelaxSettings,
) -> Result<Relaxed, RelaxError> {
    relax_measured(
        shape,
        &MeasuredVertices::measure(shape, base.discretisation, set.has_gradient_energy()),
        base,
        set,
        phi,
        settings,
        None,
    )
}

/// [`relax_fields`] for the protein amounts n_s,i = A_i φ_s,i / a_s (by
/// species, then dense slot), which are relaxed in place; the vertex areas
/// are measured once for the conversions and the relaxation. A start that
/// a shape change took outside the fields' domain is first brought back
/// inside with each amount kept ([`Relaxed::repaired`]).
pub fn relax_amounts(
    shape: Surface<'_>,
    base: BaseBending,
    set: &SpeciesSet,
    amounts: &mut [Vec<f64>],
    settings: RelaxSettings,
) -> Result<Relaxed, RelaxError> {
    let mut terms = VertexTerms::default();
    terms.measure(shape, base.discretisation);
    relax_amounts_measured(shape, &terms, base, set, amounts, settings, None)
}

/// [`relax_amounts`] on the surface's measure `terms` (in the bending's
/// discretisation), taken at `shape`'s positions; with `record`, the last
/// evaluation is written there (all but its `amounts`, which are the
/// caller's to set once it is done with them).
pub fn relax_amounts_measured(
    shape: Surface<'_>,
    terms: &VertexTerms,
    base: BaseBending,
    set: &SpeciesSet,
    amounts: &mut [Vec<f64>],
    settings: RelaxSettings,
    record: Option<&mut Evaluated>,
) -> Result<Relaxed, RelaxError> {
    let v = MeasuredVertices::from_terms(shape, terms, set.has_gradient_energy());
    let mut phi = crate::species::state::fractions(set, amounts, &v.areas);
    let repaired = bring_inside(&mut phi, &v.areas);
    let mut relaxed = relax_measured(shape, &v, base, set, &mut phi, settings, record)?;
    relaxed.repaired = repaired;
    let back = crate::species::state::amounts(set, &phi, &v.areas);
    for (n, x) in amounts.iter_mut().zip(back) {
        *n = x;
    }
    Ok(relaxed)
}

/// The limits of a step `dp` from the fractions `p` of one vertex (pairs
/// (p, dp) by species): the largest multiple of it, at most 1, that goes
/// [`TO_BOUNDARY`] of the way to a bound φ > 0 or Σφ < 1, and the largest
/// change of a fraction, or of the solvent's, relative to it.
fn step_limits(steps: impl Iterator<Item = (f64, f64)>) -> (f64, f64) {
    let (mut alpha, mut relative): (f64, f64) = (1.0, 0.0);
    let (mut total_step, mut bare) = (0.0, 1.0);
    for (p, dp) in steps {
        if dp < 0.0 {
            alpha = alpha.min(TO_BOUNDARY * p / -dp);
        }
        relative = relative.max(dp.abs() / p);
        total_step += dp;
        bare -= p;
    }
    if total_step > 0.0 {
        alpha = alpha.min(TO_BOUNDARY * bare / total_step);
    }
    (alpha, relative.max(total_step.abs() / bare))
}

/// Copies `src` into `dst`, reusing its buffers.
pub fn copy_into(dst: &mut Vec<Vec<f64>>, src: &[Vec<f64>]) {
    dst.resize(src.len(), Vec::new());
    for (d, s) in dst.iter_mut().zip(src) {
        d.clone_from(s);
    }
}

/// The most of a vertex's room (what the other species leave) a fraction
/// brought back inside takes, and the least fraction.
const ROOM_USED: f64 = 0.99;
const LEAST_FRACTION: f64 = 1e-12;

/// Brings every fraction of `phi` (by species, then vertex of area
/// `areas`) back inside φ > 0, Σφ < 1 where a shape change took it out
/// (a remesh event squeezing a cell under its proteins), keeping each
/// species' amount Σ A_i φ_i: species by species, a fraction above
/// [`ROOM_USED`] of its room is lowered to it and one below
/// [`LEAST_FRACTION`] raised to it, and what that frees (or takes) is
/// shared by the other vertices in proportion to their room (or their
/// proteins). The relaxation that follows finds the same minimum from
/// any start. Returns the vertices changed.
fn bring_inside(phi: &mut [Vec<f64>], areas: &[f64]) -> usize {
    let n = areas.len();
    let mut changed = vec![false; n];
    for k in 0..phi.len() {
        let room = |phi: &[Vec<f64>], i: usize| {
            let others: f64 = (0..phi.len()).filter(|&s| s != k).map(|s| phi[s][i]).sum();
            ROOM_USED * (1.0 - others)
        };
        let (mut freed, mut headroom, mut held) = (0.0, 0.0, 0.0);
        let mut clipped = vec![false; n];
        for i in 0..n {
            let top = room(phi, i);
            let p = phi[k][i];
            if p > top || p < LEAST_FRACTION {
                let to = p.clamp(LEAST_FRACTION, top.max(LEAST_FRACTION));
                freed += (p - to) * areas[i];
                phi[k][i] = to;
                clipped[i] = true;
                changed[i] = true;
            } else {
                headroom += (top - p) * areas[i];
                held += p * areas[i];
            }
        }
        if freed > 0.0 && headroom > 0.0 {
            // Share what was freed by the room left, at most all of it.
            let share = (freed / headroom).min(1.0);
            for i in (0..n).filter(|&i| !clipped[i]) {
                phi[k][i] += share * (room(phi, i) - phi[k][i]);
            }
        } else if freed < 0.0 && held > 0.0 {
            // Take what was added from the proteins elsewhere.
            let share = (-freed / held).min(1.0 - LEAST_FRACTION);
            for i in (0..n).filter(|&i| !clipped[i]) {
                phi[k][i] *= 1.0 - share;
            }
        }
    }
    changed.iter().filter(|&&c| c).count()
}

/// [`relax_measured`] where every species is bound from a bulk and none has
/// a gradient energy: then no term couples two vertices, and each vertex
/// takes its own Newton steps on its S×S block until its own residual
/// (the same |∂F/∂φ_s,i − μ_s A_i/a_s|/A_i as the coupled iteration's) is
/// within the tolerance, the same bounds and the same Armijo rule on its
/// own part of Ω. A vertex already relaxed costs one evaluation, where a
/// pass of the coupled iteration would evaluate every vertex again.
/// [`Relaxed::iterations`] is then the most steps any vertex took.
fn relax_independent(
    v: &MeasuredVertices,
    base: BaseBending,
    set: &SpeciesSet,
    phi: &mut [Vec<f64>],
    settings: RelaxSettings,
    mut record: Option<&mut Evaluated>,
) -> Result<Relaxed, RelaxError> {
    let n = v.areas.len();
    let ns = set.species.len();
    let constants = HessianConstants::new(set);
    let inv_ap = constants.inv_ap;
    let mu: Vec<f64> = set
        .species
        .iter()
        .map(|s| s.chemical_potential.unwrap_or(0.0))
        .collect();
    let local = LocalEnergy::new(set, base);
    if let Some(r) = record.as_deref_mut() {
        r.local.f.resize(n, 0.0);
        r.local.df_dh.resize(n, 0.0);
        r.grad.resize(ns, Vec::new());
        for g in &mut r.grad {
            g.resize(n, 0.0);
        }
    }
    let (mut at, mut d, mut trial) = ([0.0; MAX_SPECIES], [0.0; MAX_SPECIES], [0.0; MAX_SPECIES]);
    let (mut g, mut step) = ([0.0; MAX_SPECIES], [0.0; MAX_SPECIES]);
    let mut h: Block = [[0.0; MAX_SPECIES]; MAX_SPECIES];
    let (mut most, mut residual, mut omega) = (0, 0.0f64, 0.0);
    for i in 0..n {
        let (a, inv_area) = (v.areas[i], 1.0 / v.areas[i]);
        let curvature = v.interior[i].then_some(v.curvature[i]);
        for k in 0..ns {
            at[k] = phi[k][i];
        }
        // This vertex's part of Ω at `x`, writing ∂F/∂φ into `d`.
        let part = |x: &[f64], d: &mut [f64]| {
            let (f, df_dh) = local.at(&x[..ns], curvature, d);
            let exchanged: f64 = (0..ns).map(|s| mu[s] * a * inv_ap[s] * x[s]).sum();
            (a * f - exchanged, f, df_dh)
        };
        let mut steps = 0;
        let (mut value, mut f, mut df_dh) = part(&at, &mut d);
        loop {
            let mut r: f64 = 0.0;
            for s in 0..ns {
                g[s] = a * d[s] - mu[s] * (a * inv_ap[s]);
                r = r.max(g[s].abs() * inv_area);
            }
            if r <= settings.tolerance {
                residual = residual.max(r);
                break;
            }
            if steps >= settings.max_iterations || r.is_nan() {
                return Err(RelaxError::NotConverged {
                    iterations: steps,
                    residual: r,
                    tolerance: settings.tolerance,
                });
            }
            // The Newton step on this vertex's block.
            v.hessian(i, &constants, base, set, phi, &mut h);
            factorise(&mut h, ns);
            step[..ns].copy_from_slice(&g[..ns]);
            cholesky_solve(&h, ns, &mut step[..ns]);
            let mut slope = 0.0;
            for s in 0..ns {
                step[s] = -step[s];
                slope += g[s] * step[s];
            }
            let (mut alpha, relative) = step_limits((0..ns).map(|s| (at[s], step[s])));
            if relative > QUADRATIC_REGIME {
                // Armijo backtracking on this vertex's part of Ω.
                let roundoff = 1e-14 * value.abs().max(1.0);
                loop {
                    for s in 0..ns {
                        trial[s] = at[s] + alpha * step[s];
                    }
                    let tried = part(&trial, &mut d).0;
                    if tried <= value + 1e-4 * alpha * slope || -alpha * slope <= roundoff {
                        break;
                    }
                    alpha *= 0.5;
                    if alpha < 1e-12 {
                        return Err(RelaxError::NotConverged {
                            iterations: steps,
                            residual: r,
                            tolerance: settings.tolerance,
                        });
                    }
                }
            } else {
                alpha = 1.0;
            }
            for s in 0..ns {
                at[s] += alpha * step[s];
                phi[s][i] = at[s];
            }
            steps += 1;
            (value, f, df_dh) = part(&at, &mut d);
        }
        most = most.max(steps);
        omega += value;
        if let Some(r) = record.as_deref_mut() {
            (r.local.f[i], r.local.df_dh[i]) = (f, df_dh);
            for s in 0..ns {
                r.grad[s][i] = a * d[s];
            }
        }
    }
    if let Some(r) = record {
        copy_into(&mut r.phi, phi);
    }
    Ok(Relaxed {
        iterations: most,
        residual,
        chemical_potentials: mu,
        grand_potential: omega,
        repaired: 0,
    })
}

/// [`relax_fields`] on the vertex quantities `v` of `shape`; with `record`,
/// the last evaluation is written there (but its `amounts`).
fn relax_measured(
    shape: Surface<'_>,
    v: &MeasuredVertices,
    base: BaseBending,
    set: &SpeciesSet,
    phi: &mut [Vec<f64>],
    settings: RelaxSettings,
    mut record: Option<&mut Evaluated>,
) -> Result<Relaxed, RelaxError> {
    let n = shape.vertex_count();
    let ns = set.species.len();
    for i in 0..n {
        let total: f64 = phi.iter().map(|p| p[i]).sum();
        for (k, p) in phi.iter().enumerate() {
            if !(p[i] > 0.0 && total < 1.0) {
                return Err(RelaxError::Outside {
                    species: k,
                    vertex: i,
                    value: p[i],
                });
            }
        }
    }
    let conserved: Vec<usize> = (0..ns)
        .filter(|&s| set.species[s].reservoir == Reservoir::Conserved)
        .collect();
    if conserved.is_empty() && !set.has_gradient_energy() {
        return relax_independent(v, base, set, phi, settings, record);
    }
    let bulk_mu: Vec<f64> = set
        .species
        .iter()
        .map(|s| s.chemical_potential.unwrap_or(0.0))
        .collect();
    // Per species: 1/a_s, whether conserved; per vertex 1/A_i.
    let constants = HessianConstants::new(set);
    let inv_ap = constants.inv_ap;
    let mut is_conserved = [false; MAX_SPECIES];
    for (k, sp) in set.species.iter().enumerate() {
        is_conserved[k] = sp.reservoir == Reservoir::Conserved;
    }
    let inv_area: Vec<f64> = v.areas.iter().map(|a| 1.0 / a).collect();
    let weight = |i: usize, s: usize| v.areas[i] * inv_ap[s];
    let local = LocalEnergy::new(set, base);
    let mut grad = vec![vec![0.0; n]; ns];
    // Ω and, with `grad`, ∂F/∂φ: the local energies at the vertices'
    // areas and curvatures, measured once, and the gradient energies.
    let omega =
        |phi: &[Vec<f64>], grad: Option<&mut Vec<Vec<f64>>>, record: Option<&mut LocalValues>| {
            let grad = grad.map(|g| &mut g[..]);
            let f = v.free_energy_recorded(shape, &local, set, phi, grad, record);
            let exchanged: f64 = (0..ns)
                .filter(|s| !conserved.contains(s))
                .map(|s| bulk_mu[s] * (0..n).map(|i| weight(i, s) * phi[s][i]).sum::<f64>())
                .sum();
            f - exchanged
        };
    let nc = conserved.len();
    // Per vertex: H⁻¹G and H⁻¹(w e_c) for each conserved c.
    let mut u = vec![0.0; n * ns];
    let mut vc = vec![0.0; n * ns * nc];
    let mut step = vec![vec![0.0; n]; ns];
    let mut lambda = vec![0.0; nc];
    let mut trial: Vec<Vec<f64>> = phi.to_vec();
    let mut iterations = 0;
    loop {
        let value = omega(
            phi,
            Some(&mut grad),
            record.as_deref_mut().map(|r| &mut r.local),
        );
        // Every return below is at these fractions.
        let mut recorded = |phi: &[Vec<f64>], grad: &[Vec<f64>]| {
            if let Some(r) = record.as_deref_mut() {
                copy_into(&mut r.phi, phi);
                copy_into(&mut r.grad, grad);
            }
        };
        // The residual at the best multipliers, without the Hessian: a
        // bulk species' |∂F/∂φ − μw|/A at its μ; a conserved species'
        // (a_s ∂F/∂φ / A) spreads about its multiplier, best placed at
        // the midrange, where the largest |∂F/∂φ − λw|/A is half the
        // spread over a_s. Within the tolerance, the fields are relaxed.
        let mut best = bulk_mu.clone();
        let mut certified: f64 = 0.0;
        for s in 0..ns {
            let a = set.species[s].area_per_protein;
            if is_conserved[s] {
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for i in 0..n {
                    let q = grad[s][i] * inv_area[i] * a;
                    lo = lo.min(q);
                    hi = hi.max(q);
                }
                best[s] = 0.5 * (lo + hi);
                certified = certified.max(0.5 * (hi - lo) * inv_ap[s]);
            } else {
                for i in 0..n {
                    let r = (grad[s][i] - best[s] * weight(i, s)).abs() * inv_area[i];
                    certified = certified.max(r);
                }
            }
        }
        if certified <= settings.tolerance {
            recorded(phi, &grad);
            return Ok(Relaxed {
                iterations,
                residual: certified,
                chemical_potentials: best,
                grand_potential: value,
                repaired: 0,
            });
        }
        // The local Hessian blocks and the solves (each block's S×S corner
        // is written in full for every vertex).
        let mut h: Block = [[0.0; MAX_SPECIES]; MAX_SPECIES];
        for i in 0..n {
            v.hessian(i, &constants, base, set, phi, &mut h);
            factorise(&mut h, ns);
            let factor = &h;
            let ui = &mut u[i * ns..(i + 1) * ns];
            for s in 0..ns {
                ui[s] = grad[s][i]
                    - match is_conserved[s] {
                        true => 0.0,
                        false => bulk_mu[s] * weight(i, s),
                    };
            }
            cholesky_solve(factor, ns, ui);
            for (ci, &c) in conserved.iter().enumerate() {
                let x = &mut vc[(i * nc + ci) * ns..(i * nc + ci + 1) * ns];
                x.fill(0.0);
                x[c] = weight(i, c);
                cholesky_solve(factor, ns, x);
            }
        }
        // The multipliers: Σ_i w_i,c' δ_i,c' = 0 with δ_i = −u_i + Σ_c λ_c v^c_i.
        if nc > 0 {
            let mut m: Block = [[0.0; MAX_SPECIES]; MAX_SPECIES];
            let mut b = [0.0; MAX_SPECIES];
            for i in 0..n {
                for (r, &cr) in conserved.iter().enumerate() {
                    let w = weight(i, cr);
                    b[r] += w * u[i * ns + cr];
                    for ci in 0..nc {
                        m[r][ci] += w * vc[(i * nc + ci) * ns + cr];
                    }
                }
            }
            factorise(&mut m, nc);
            let l = &m;
            cholesky_solve(l, nc, &mut b[..nc]);
            lambda.copy_from_slice(&b[..nc]);
        }
        // The residual with these multipliers, and the step.
        let potentials = || {
            let mut mu = bulk_mu.clone();
            for (ci, &c) in conserved.iter().enumerate() {
                mu[c] = lambda[ci];
            }
            mu
        };
        let mus = potentials();
        let mut residual: f64 = 0.0;
        let mut slope = 0.0;
        for i in 0..n {
            for s in 0..ns {
                let mu = mus[s];
                residual = residual.max((grad[s][i] - mu * weight(i, s)).abs() * inv_area[i]);
                let mut x = -u[i * ns + s];
                for ci in 0..nc {
                    x += lambda[ci] * vc[(i * nc + ci) * ns + s];
                }
                step[s][i] = x;
                // (G − λw)·δ: the conserved part λ Σ w δ vanishes exactly
                // in exact arithmetic, and left out it adds no round-off.
                slope += (grad[s][i] - mu * weight(i, s)) * x;
            }
        }
        if residual <= settings.tolerance {
            recorded(phi, &grad);
            return Ok(Relaxed {
                iterations,
                residual,
                chemical_potentials: mus,
                grand_potential: value,
                repaired: 0,
            });
        }
        if iterations >= settings.max_iterations || slope.is_nan() {
            return Err(RelaxError::NotConverged {
                iterations,
                residual,
                tolerance: settings.tolerance,
            });
        }
        // A fraction of the way to the bounds at most; `relative` is the
        // largest change of a fraction or of the solvent's, relative to it.
        let mut alpha: f64 = 1.0;
        let mut relative: f64 = 0.0;
        for i in 0..n {
            let (a, r) = step_limits((0..ns).map(|s| (phi[s][i], step[s][i])));
            alpha = alpha.min(a);
            relative = relative.max(r);
        }
        if relative <= QUADRATIC_REGIME {
            // The full Newton step, without measuring Ω there: the
            // quadratic model is then exact but for the entropies' cubic
            // terms, at most a third of `relative` of the predicted
            // decrease, so the step descends.
            for s in 0..ns {
                for i in 0..n {
                    phi[s][i] += step[s][i];
                }
            }
            iterations += 1;
        } else {
            // Armijo backtracking; a decrease below Ω's round-off is taken.
            let roundoff = 1e-14 * value.abs().max(1.0);
            let accepted = loop {
                for s in 0..ns {
                    for i in 0..n {
                        trial[s][i] = phi[s][i] + alpha * step[s][i];
                    }
                }
                let tried = omega(&trial, None, None);
                if tried <= value + 1e-4 * alpha * slope || -alpha * slope <= roundoff {
                    // (A slope ≥ 0 is round-off near the minimum: the step is
                    // taken as it is.)
                    break true;
                }
                alpha *= 0.5;
                if alpha < 1e-12 {
                    break false;
                }
            };
            if !accepted {
                return Err(RelaxError::NotConverged {
                    iterations,
                    residual,
                    tolerance: settings.tolerance,
                });
            }
            for (p, t) in phi.iter_mut().zip(&trial) {
                p.copy_from_slice(t);
            }
            iterations += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::bending::BendingDiscretisation;
    use crate::mesh::ellipsoid;
    use crate::mesh::geometry::face_geometry;
    use crate::species::free_energy::{Fields, FreeEnergyScratch, Hold, free_energy};
    use crate::species::params::Species;

    /// The topology of `mesh`, its dense slots in the mesh's vertex order.
    fn topology_of(mesh: &crate::mesh::SurfaceMesh) -> crate::mesh::topology::Topology {
        let mut m = crate::mesh::membrane::Membrane::from_mesh(mesh, false).unwrap();
        m.topology().unwrap().clone()
    }

    fn species(name: &str, c: f64, reservoir: Reservoir, mu: Option<f64>) -> Species {
        Species {
            curvature_coupling: c,
            reservoir,
            chemical_potential: mu,
            ..Species::new(name, 0.05, crate::species::params::Initial::Fraction(0.1))
        }
    }

    /// Relaxes `set` from uniform fractions `start` on the 2562-vertex
    /// ellipsoid (κ = 1 Ē, C0 = 0) and checks, at every vertex, the
    /// multi-species Fermi-Dirac relation
    /// φ_s = x_s / (1 + Σ_t x_t), x_s = e^{(μ_s − ε_s)/k_BT},
    /// ε_s = −a κ c_s (h − Σ_t c_t φ_t) (equal areas per protein), to 1e-8,
    /// and every conserved count to 1e-12 relative.
    fn check_fermi_dirac(set: &SpeciesSet, start: &[f64]) {
        set.validate().unwrap();
        let mesh = ellipsoid(4, [1.0, 1.3, 0.8], 0.0, 0);
        let n = mesh.vertex_count();
        assert_eq!(n, 2562);
        let topology = topology_of(&mesh);
        let mut geometry = Vec::new();
        face_geometry(&mesh.positions, &topology.faces, &mut geometry);
        let shape = Surface {
            positions: &mesh.positions,
            topology: &topology,
            geometry: &geometry,
            boundary: None,
        };
        let base = BaseBending {
            kappa: 1.0,
            c0: 0.0,
            discretisation: BendingDiscretisation::Cotangent,
        };
        let mut phi: Vec<Vec<f64>> = start.iter().map(|&p| vec![p; n]).collect();
        let v = MeasuredVertices::measure(shape, base.discretisation, set.has_gradient_energy());
        let count = |phi: &[Vec<f64>], s: usize| -> f64 {
            (0..n).map(|i| v.areas[i] * phi[s][i]).sum::<f64>() / 0.05
        };
        let before: Vec<f64> = (0..set.species.len()).map(|s| count(&phi, s)).collect();
        let settings = RelaxSettings {
            tolerance: 1e-11,
            max_iterations: 100,
        };
        let relaxed = relax_fields(shape, base, set, &mut phi, settings).unwrap();
        assert!(relaxed.iterations < 30, "{relaxed:?}");
        let mu = &relaxed.chemical_potentials;
        let kbt = set.temperature;
        let mut spread = (f64::INFINITY, 0.0f64);
        for i in 0..n {
            let c: f64 = set
                .species
                .iter()
                .enumerate()
                .map(|(s, sp)| sp.curvature_coupling * phi[s][i])
                .sum();
            let x: Vec<f64> = set
                .species
                .iter()
                .enumerate()
                .map(|(s, sp)| {
                    let eps = -0.05 * sp.curvature_coupling * (v.curvature[i] - c);
                    ((mu[s] - eps) / kbt).exp()
                })
                .collect();
            let sum: f64 = x.iter().sum();
            for (s, x) in x.iter().enumerate() {
                let expected = x / (1.0 + sum);
                assert!(
                    (phi[s][i] - expected).abs() <= 1e-8,
                    "species {s}, vertex {i}: φ {} against {expected}",
                    phi[s][i]
                );
            }
            spread = (spread.0.min(phi[0][i]), spread.1.max(phi[0][i]));
        }
        // The curvature sorts the proteins: not a uniform field.
        assert!(
            spread.1 > 1.5 * spread.0,
            "φ from {} to {}",
            spread.0,
            spread.1
        );
        for (s, sp) in set.species.iter().enumerate() {
            if sp.reservoir == Reservoir::Conserved {
                let after = count(&phi, s);
                assert!(
                    (after - before[s]).abs() <= 1e-12 * before[s],
                    "species {s}: {} proteins before, {after} after",
                    before[s]
                );
            }
        }
    }

    #[test]
    fn one_conserved_species_on_a_frozen_ellipsoid_follows_fermi_dirac() {
        let set = SpeciesSet {
            species: vec![species("bar", 4.0, Reservoir::Conserved, None)],
            interactions: vec![],
            temperature: 0.1,
        };
        check_fermi_dirac(&set, &[0.2]);
    }

    #[test]
    fn a_conserved_and_a_bulk_species_on_a_frozen_ellipsoid_follow_fermi_dirac() {
        let set = SpeciesSet {
            species: vec![
                species("bar", 4.0, Reservoir::Conserved, None),
                species("epsin", -3.0, Reservoir::Bulk, Some(-0.05)),
            ],
            interactions: vec![],
            temperature: 0.1,
        };
        check_fermi_dirac(&set, &[0.2, 0.1]);
    }

    /// Species bound from a bulk without gradient energies relax vertex by
    /// vertex ([`relax_independent`]): one, and two of opposite coupling,
    /// follow the Fermi-Dirac relation to 1e-8.
    #[test]
    fn bulk_species_on_a_frozen_ellipsoid_follow_fermi_dirac_vertex_by_vertex() {
        let one = SpeciesSet {
            species: vec![species("bar", 4.0, Reservoir::Bulk, Some(-0.2))],
            interactions: vec![],
            temperature: 0.1,
        };
        check_fermi_dirac(&one, &[0.2]);
        let two = SpeciesSet {
            species: vec![
                species("bar", 4.0, Reservoir::Bulk, Some(-0.2)),
                species("epsin", -3.0, Reservoir::Bulk, Some(-0.05)),
            ],
            interactions: vec![],
            temperature: 0.1,
        };
        check_fermi_dirac(&two, &[0.2, 0.1]);
    }

    /// With gradient energies, a rigidity change, binding and a demixing
    /// interaction (the blocks then approximate the Hessian), on an open
    /// cap: the relaxation still converges, and the point it reaches is a
    /// minimum: count-preserving perturbations raise Ω.
    #[test]
    fn coupled_species_with_gradient_energies_relax_to_a_minimum() {
        use crate::fd::perturbed_patches;
        let mesh = perturbed_patches(5)[0].clone();
        let n = mesh.vertex_count();
        let topology = topology_of(&mesh);
        let mut geometry = Vec::new();
        face_geometry(&mesh.positions, &topology.faces, &mut geometry);
        let boundary = topology.boundary_mask();
        assert!(boundary.iter().any(|b| *b));
        let shape = Surface {
            positions: &mesh.positions,
            topology: &topology,
            geometry: &geometry,
            boundary: Some(&boundary),
        };
        let mut bar = species("bar", 3.0, Reservoir::Conserved, None);
        (bar.rigidity_change, bar.gradient_energy, bar.binding_energy) = (0.5, 0.02, -0.2);
        let mut epsin = species("epsin", -2.0, Reservoir::Bulk, Some(-0.1));
        (epsin.area_per_protein, epsin.gradient_energy) = (0.03, 0.01);
        let set = SpeciesSet {
            species: vec![bar, epsin],
            interactions: vec![crate::species::params::Interaction {
                species: ("bar".into(), "bar".into()),
                chi: -1.0,
            }],
            temperature: 0.1,
        };
        set.validate().unwrap();
        let base = BaseBending {
            kappa: 1.0,
            c0: 0.2,
            discretisation: BendingDiscretisation::Cotangent,
        };
        let mut phi = vec![vec![0.3; n], vec![0.2; n]];
        let settings = RelaxSettings {
            tolerance: 1e-10,
            max_iterations: 500,
        };
        let relaxed = relax_fields(shape, base, &set, &mut phi, settings).unwrap();
        let omega = |phi: &[Vec<f64>]| {
            let mut s = FreeEnergyScratch::default();
            let f = free_energy(
                shape,
                base,
                &set,
                Fields::Fractions(phi),
                Hold::Fraction,
                &mut s,
                None,
            );
            let v =
                MeasuredVertices::measure(shape, base.discretisation, set.has_gradient_energy());
            f + 0.1 * (0..n).map(|i| v.areas[i] * phi[1][i]).sum::<f64>() / 0.03
        };
        let at_minimum = omega(&phi);
        assert!((at_minimum - relaxed.grand_potential).abs() <= 1e-12 * at_minimum.abs());
        // Move protein between two vertices of equal area weight (count
        // kept), or change the bulk species anywhere.
        let v = MeasuredVertices::measure(shape, base.discretisation, set.has_gradient_energy());
        for (i, j) in [(3, 17), (20, 41), (8, 30)] {
            for t in [1e-4, -1e-4] {
                let mut p = phi.clone();
                p[0][i] += t / v.areas[i];
                p[0][j] -= t / v.areas[j];
                assert!(omega(&p) > at_minimum, "bar moved {i} → {j} by {t}");
                let mut p = phi.clone();
                p[1][i] += t;
                assert!(omega(&p) > at_minimum, "epsin at {i} changed by {t}");
            }
        }
        assert!(relaxed.iterations > 0 && relaxed.residual <= 1e-10);
    }

    #[test]
    fn a_start_outside_the_domain_is_brought_inside_with_its_amounts() {
        // Two species on eight vertices of unequal areas; vertex 2 is
        // squeezed (φ sums above 1), vertex 5 has a negative fraction.
        let areas = [1.0, 0.5, 0.2, 1.5, 0.8, 1.0, 0.7, 1.2];
        let mut phi = vec![
            vec![0.3, 0.2, 0.9, 0.1, 0.25, -0.01, 0.2, 0.3],
            vec![0.1, 0.1, 0.3, 0.2, 0.1, 0.2, 0.1, 0.1],
        ];
        let amount = |phi: &[Vec<f64>], k: usize| -> f64 {
            phi[k].iter().zip(&areas).map(|(p, a)| p * a).sum()
        };
        let before = [amount(&phi, 0), amount(&phi, 1)];
        let changed = bring_inside(&mut phi, &areas);
        assert_eq!(changed, 2);
        for k in 0..2 {
            assert!((amount(&phi, k) - before[k]).abs() <= 1e-15 * before[k]);
        }
        for i in 0..areas.len() {
            let total = phi[0][i] + phi[1][i];
            assert!(
                phi[0][i] > 0.0 && phi[1][i] > 0.0 && total < 1.0,
                "{i}: {total}"
            );
        }
        // Inside already: nothing moves, to the bit.
        let inside = phi.clone();
        assert_eq!(bring_inside(&mut phi, &areas), 0);
        assert_eq!(phi, inside);
    }
}
