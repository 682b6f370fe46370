//! The species' free energy on a triangulated surface (the terms of
//! [`crate::species::params`]) in the discretisation of the cotangent
//! bending ([`crate::energy::bending`]): per vertex i, the mixed Voronoi
//! area A_i and the signed total curvature h_i = s_i|L_i|/(2A_i);
//!
//! F = Σ_i A_i [½κ_i (h_i − C0_i)² − ½κ (h_i − C0)²] (interior vertices)
//!   + Σ_i A_i f_loc(φ_i)                             (every vertex)
//!   + Σ_s ½η_s Σ_faces Σ_k ½cot_k (φ_s,a − φ_s,b)²   (edge k = (a, b)),
//!
//! the last the cotangent Dirichlet energy ½η∫|∇φ|². It is the energy a
//! species adds to the `Bending` term's (the coupled bending is written as
//! a difference, so the membrane's own bending stays that term's).
//!
//! The derivatives are analytic: ∂F/∂φ_s,i, and the shape force −∂F/∂r
//! either at fixed fractions φ ([`Hold::Fraction`]) or at fixed protein
//! amounts n_i = A_i φ_i / a_p ([`Hold::Amount`]: what a surface carrying
//! its proteins feels; the fractions dilute as the vertex areas grow,
//! ∂φ_i/∂A_i = −φ_i/A_i).

use crate::mesh::geometry::{Corners, vertex_curvature_terms};
use crate::species::params::{MAX_SPECIES, SpeciesSet};
use glam::DVec3;

/// What stays fixed when the shape moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hold {
    /// The area fractions φ.
    Fraction,
    /// The protein amounts A_i φ_i / a_p.
    Amount,
}

/// The membrane's own bending, which the coupling modifies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaseBending {
    /// κ (Ē).
    pub kappa: f64,
    /// C0 (1/l̄, total curvature).
    pub c0: f64,
}

/// Reusable per-vertex buffers.
#[derive(Clone, Debug, Default)]
pub struct FreeEnergyScratch {
    areas: Vec<f64>,
    laplacians: Vec<DVec3>,
    normals: Vec<DVec3>,
    g_lap: Vec<DVec3>,
    g_area: Vec<f64>,
}

/// Where the derivatives go.
pub struct Derivatives<'a> {
    /// −∂F/∂r is added here (Ē/l̄), by dense slot.
    pub force: &'a mut [DVec3],
    /// ∂F/∂φ_s,i is written here (Ē), by species then dense slot.
    pub phi: &'a mut [Vec<f64>],
}

/// The signed total curvature h = s|L|/(2A) of a vertex with cotangent
/// Laplacian `l`, area-weighted normal `normal` and area `area`, with the
/// sign s (negative where L points against the normal) and |L|.
pub(crate) fn signed_curvature(l: DVec3, normal: DVec3, area: f64) -> (f64, f64, f64) {
    let len = l.length();
    let sign = if l.dot(normal) < 0.0 { -1.0 } else { 1.0 };
    (sign * len / (2.0 * area), sign, len)
}

/// (x ln x, ln x), the first continued by 0 at x = 0.
fn x_ln_x(x: f64) -> (f64, f64) {
    let ln = x.ln();
    (if x > 0.0 { x * ln } else { 0.0 }, ln)
}

/// The local free energy per area of one vertex, f_loc(φ) plus, on an
/// interior vertex, the coupled bending at its curvature h, with the
/// constants of a species set.
pub(crate) struct LocalEnergy<'a> {
    set: &'a SpeciesSet,
    base: BaseBending,
    /// k_BT / a_0, the solvent's entropy per area.
    kbt_a0: f64,
    /// k_BT / a_s, each species' entropy per area.
    kbt_ap: [f64; MAX_SPECIES],
    chi: Vec<Vec<f64>>,
}

impl<'a> LocalEnergy<'a> {
    pub(crate) fn new(set: &'a SpeciesSet, base: BaseBending) -> Self {
        let kbt = set.temperature;
        let mut kbt_ap = [0.0; MAX_SPECIES];
        for (k, s) in set.species.iter().enumerate() {
            kbt_ap[k] = kbt / s.area_per_protein;
        }
        Self {
            set,
            base,
            kbt_a0: kbt / set.solvent_area(),
            kbt_ap,
            chi: set.interaction_matrix(),
        }
    }

    /// f (Ē/l̄²) at the fractions `phi` (one per species) and, on an
    /// interior vertex, the curvature `h`; writes ∂f/∂φ_s into `dphi` and
    /// returns (f, ∂f/∂h).
    pub(crate) fn at(&self, phi: &[f64], h: Option<f64>, dphi: &mut [f64]) -> (f64, f64) {
        let species = &self.set.species;
        let bare = 1.0 - phi.iter().sum::<f64>();
        let (b_ln_b, ln_b) = x_ln_x(bare);
        let mut f = self.kbt_a0 * b_ln_b;
        let solvent = self.kbt_a0 * (ln_b + 1.0);
        for (k, sp) in species.iter().enumerate() {
            let p = phi[k];
            let (p_ln_p, ln_p) = x_ln_x(p);
            f += sp.binding_energy * p + self.kbt_ap[k] * p_ln_p;
            dphi[k] = sp.binding_energy + self.kbt_ap[k] * (ln_p + 1.0) - solvent;
        }
        for (k, row) in self.chi.iter().enumerate() {
            for (l, c) in row.iter().enumerate().skip(k) {
                f += c * phi[k] * phi[l];
                dphi[k] += c * phi[l];
                dphi[l] += c * phi[k];
            }
        }
        let Some(h) = h else {
            return (f, 0.0);
        };
        let base = self.base;
        let (mut kappa, mut c0) = (base.kappa, base.c0);
        for (k, sp) in species.iter().enumerate() {
            kappa += sp.rigidity_change * phi[k];
            c0 += sp.curvature_coupling * phi[k];
        }
        let (d, d0) = (h - c0, h - base.c0);
        f += 0.5 * kappa * d * d - 0.5 * base.kappa * d0 * d0;
        for (k, sp) in species.iter().enumerate() {
            dphi[k] += 0.5 * sp.rigidity_change * d * d - kappa * d * sp.curvature_coupling;
        }
        (f, kappa * d - base.kappa * d0)
    }
}

/// The gradient energies Σ_s ½η_s Σ_faces Σ_k ½cot_k (φ_s,a − φ_s,b)²
/// (Ē); with `dphi`, adds their ∂/∂φ; with `cot_adjoints`, adds their
/// ∂/∂cot_k per face.
pub(crate) fn gradient_energy(
    faces: &[[u32; 3]],
    geometry: &[Corners],
    set: &SpeciesSet,
    phi: &[Vec<f64>],
    mut dphi: Option<&mut [Vec<f64>]>,
    mut cot_adjoints: Option<&mut Vec<[f64; 3]>>,
) -> f64 {
    let mut energy = 0.0;
    for (fi, (face, c)) in faces.iter().zip(geometry).enumerate() {
        for k in 0..3 {
            let (va, vb) = (face[(k + 1) % 3] as usize, face[(k + 2) % 3] as usize);
            for (sk, sp) in set.species.iter().enumerate() {
                if sp.gradient_energy == 0.0 {
                    continue;
                }
                let diff = phi[sk][va] - phi[sk][vb];
                let w = 0.25 * sp.gradient_energy;
                energy += w * c.cot[k] * diff * diff;
                if let Some(g) = cot_adjoints.as_deref_mut() {
                    g[fi][k] += w * diff * diff;
                }
                if let Some(d) = dphi.as_deref_mut() {
                    d[sk][va] += 2.0 * w * c.cot[k] * diff;
                    d[sk][vb] -= 2.0 * w * c.cot[k] * diff;
                }
            }
        }
    }
    energy
}

/// The fields a free energy is evaluated for, by species, then dense slot.
#[derive(Clone, Copy, Debug)]
pub enum Fields<'a> {
    /// The area fractions φ (each in (0, 1), their sum below 1).
    Fractions(&'a [Vec<f64>]),
    /// The protein amounts n = A φ / a_p, turned into fractions at the
    /// vertex areas the evaluation measures.
    Amounts(&'a [Vec<f64>]),
}

/// The species' free energy (Ē) of the mesh `faces` with per-face
/// `geometry` and `n` vertices, for the `fields`. `boundary` marks the
/// vertices of an open mesh's rims, which carry no bending (as in
/// [`crate::energy::bending`]). With `out`, adds the shape force to
/// `out.force` under `hold` and writes ∂F/∂φ to `out.phi`.
#[allow(clippy::too_many_arguments)]
pub fn free_energy(
    faces: &[[u32; 3]],
    geometry: &[Corners],
    n: usize,
    base: BaseBending,
    set: &SpeciesSet,
    fields: Fields<'_>,
    boundary: Option<&[bool]>,
    hold: Hold,
    scratch: &mut FreeEnergyScratch,
    mut out: Option<Derivatives<'_>>,
) -> f64 {
    let s = scratch;
    let species = &set.species;
    let local = LocalEnergy::new(set, base);
    let (areas, laplacians) = (&mut s.areas, &mut s.laplacians);
    vertex_curvature_terms(faces, geometry, areas, laplacians, Some(&mut s.normals), n);
    let converted;
    let phi = match fields {
        Fields::Fractions(phi) => phi,
        Fields::Amounts(amounts) => {
            converted = crate::species::state::fractions(set, amounts, &s.areas);
            &converted[..]
        }
    };
    s.g_lap.clear();
    s.g_lap.resize(n, DVec3::ZERO);
    s.g_area.clear();
    s.g_area.resize(n, 0.0);
    if let Some(o) = out.as_mut() {
        for d in o.phi.iter_mut() {
            d.clear();
            d.resize(n, 0.0);
        }
    }
    let mut energy = 0.0;
    let mut at = [0.0; MAX_SPECIES];
    let mut dphi = [0.0; MAX_SPECIES];
    for i in 0..n {
        let a = s.areas[i];
        for (k, p) in phi.iter().enumerate() {
            at[k] = p[i];
        }
        // The coupled bending on interior vertices only.
        let interior = !boundary.is_some_and(|b| b[i]);
        let l = s.laplacians[i];
        let (h, sign, len) = signed_curvature(l, s.normals[i], a);
        let (f, mut df_dh) = local.at(&at[..species.len()], interior.then_some(h), &mut dphi);
        if interior {
            // h = s|L|/(2A): ∂(A f)/∂L = ½ f'(h) s L/|L|; ∂(A f)/∂A gets −h f'(h).
            if len > 0.0 {
                s.g_lap[i] = l * (0.5 * df_dh * sign / len);
            }
            df_dh *= h;
        }
        energy += a * f;
        s.g_area[i] = f - df_dh;
        if let Some(o) = out.as_mut() {
            for (k, d) in dphi.iter().take(species.len()).enumerate() {
                o.phi[k][i] = a * d;
            }
        }
    }
    // The gradient energies.
    let mut cot_adjoints = Vec::new();
    if set.has_gradient_energy() {
        cot_adjoints.resize(faces.len(), [0.0; 3]);
        energy += gradient_energy(
            faces,
            geometry,
            set,
            phi,
            out.as_mut().map(|o| &mut *o.phi),
            Some(&mut cot_adjoints),
        );
    }
    let Some(o) = out else {
        return energy;
    };
    if hold == Hold::Amount {
        // φ_i = a_p n_i / A_i: ∂φ_i/∂A_i = −φ_i/A_i.
        for i in 0..n {
            let a = s.areas[i];
            for (k, d) in o.phi.iter().enumerate() {
                s.g_area[i] -= d[i] * phi[k][i] / a;
            }
        }
    }
    for (fi, (face, c)) in faces.iter().zip(geometry).enumerate() {
        let [i0, i1, i2] = face.map(|v| v as usize);
        let mut g = c.backward(
            [s.g_lap[i0], s.g_lap[i1], s.g_lap[i2]],
            [s.g_area[i0], s.g_area[i1], s.g_area[i2]],
        );
        if let Some(gc) = cot_adjoints.get(fi) {
            let extra = c.cot_backward(*gc);
            for k in 0..3 {
                g[k] += extra[k];
            }
        }
        o.force[i0] -= g[0];
        o.force[i1] -= g[1];
        o.force[i2] -= g[2];
    }
    energy
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fd::{perturbed_icosphere, perturbed_patches};
    use crate::mesh::SurfaceMesh;
    use crate::mesh::geometry::face_geometry;
    use crate::species::params::{Interaction, Species};
    use rand::{RngExt, SeedableRng};

    fn two_species() -> SpeciesSet {
        let sp = |name: &str, a: f64, c: f64, dk: f64, eps: f64, eta: f64| Species {
            name: name.into(),
            area_per_protein: a,
            curvature_coupling: c,
            rigidity_change: dk,
            binding_energy: eps,
            gradient_energy: eta,
            initial: crate::species::params::Initial::Fraction(0.1),
            reservoir: Default::default(),
            chemical_potential: None,
        };
        SpeciesSet {
            species: vec![
                sp("bar", 0.05, 1.5, 2.0, -0.3, 0.7),
                sp("epsin", 0.02, -0.8, -1.0, 0.2, 0.0),
            ],
            interactions: vec![
                Interaction {
                    species: ("bar".into(), "epsin".into()),
                    chi: 0.9,
                },
                Interaction {
                    species: ("bar".into(), "bar".into()),
                    chi: -0.4,
                },
            ],
            temperature: 0.1,
        }
    }

    fn fields(n: usize, seed: u64) -> Vec<Vec<f64>> {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
        (0..2)
            .map(|_| (0..n).map(|_| rng.random_range(0.05..0.4)).collect())
            .collect()
    }

    /// The mesh's faces at `positions`: their geometry and the vertex areas.
    fn geometry_at(mesh: &SurfaceMesh, positions: &[DVec3]) -> (Vec<Corners>, Vec<f64>) {
        let mut geometry = Vec::new();
        face_geometry(positions, &mesh.faces, &mut geometry);
        let (mut areas, mut laps) = (Vec::new(), Vec::new());
        let n = positions.len();
        vertex_curvature_terms(&mesh.faces, &geometry, &mut areas, &mut laps, None, n);
        (geometry, areas)
    }

    /// F of `mesh` at `positions` (κ = 5 Ē, C0 = 0.3/l̄) for the fractions
    /// `phi`, or, with `amounts`, for the fractions n_i / A_i of the
    /// amounts `phi` at these positions; with `out`, its derivatives.
    fn evaluate(
        mesh: &SurfaceMesh,
        positions: &[DVec3],
        (set, phi, amounts): (&SpeciesSet, &[Vec<f64>], bool),
        (boundary, hold): (Option<&[bool]>, Hold),
        out: Option<Derivatives<'_>>,
    ) -> f64 {
        let (geometry, areas) = geometry_at(mesh, positions);
        let phi: Vec<Vec<f64>> = match amounts {
            true => phi
                .iter()
                .map(|n| n.iter().zip(&areas).map(|(n, a)| n / a).collect())
                .collect(),
            false => phi.to_vec(),
        };
        let base = BaseBending {
            kappa: 5.0,
            c0: 0.3,
        };
        let mut s = FreeEnergyScratch::default();
        let n = positions.len();
        free_energy(
            &mesh.faces,
            &geometry,
            n,
            base,
            set,
            Fields::Fractions(&phi),
            boundary,
            hold,
            &mut s,
            out,
        )
    }

    /// Checks −∂F/∂r and ∂F/∂φ against central differences (fourth order)
    /// on `mesh`, holding fractions or amounts.
    fn check(mesh: &SurfaceMesh, boundary: Option<&[bool]>, hold: Hold, seed: u64) {
        let set = two_species();
        let n = mesh.positions.len();
        let phi = fields(n, seed);
        let mut force = vec![DVec3::ZERO; n];
        let mut dphi = vec![Vec::new(), Vec::new()];
        let derivatives = Derivatives {
            force: &mut force,
            phi: &mut dphi,
        };
        let at_rest = (&set, phi.as_slice(), false);
        let e = evaluate(
            mesh,
            &mesh.positions,
            at_rest,
            (boundary, hold),
            Some(derivatives),
        );
        assert!(e.is_finite());
        let amounts = hold == Hold::Amount;
        // The held variables: the amounts A_i φ_i (a_p cancels).
        let held: Vec<Vec<f64>> = if amounts {
            let areas = geometry_at(mesh, &mesh.positions).1;
            phi.iter()
                .map(|p| p.iter().zip(&areas).map(|(p, a)| p * a).collect())
                .collect()
        } else {
            phi.clone()
        };
        let plain = (boundary, Hold::Fraction);
        // 1e-5 l̄: on the flat disc some |L_i| are small, and the curvature
        // h_i = s|L_i|/(2A_i) bends sharply at that scale (with 1e-4 the
        // stencil's truncation error reaches 1e-4 relative there).
        let h = 1e-5;
        let diff4 = |f: &dyn Fn(f64) -> f64| {
            (f(-2.0 * h) - 8.0 * f(-h) + 8.0 * f(h) - f(2.0 * h)) / (12.0 * h)
        };
        for v in 0..n {
            let mut numeric = DVec3::ZERO;
            for c in 0..3 {
                let at = |t: f64| {
                    let mut p = mesh.positions.clone();
                    p[v][c] += t;
                    evaluate(mesh, &p, (&set, &held, amounts), plain, None)
                };
                numeric[c] = -diff4(&at);
            }
            let err = (force[v] - numeric).length();
            assert!(
                err <= 1e-6 * numeric.length() + 1e-8,
                "{hold:?}, vertex {v}: analytic {:?}, numeric {numeric:?}",
                force[v]
            );
        }
        for (k, d) in dphi.iter().enumerate() {
            for v in 0..n {
                let at = |t: f64| {
                    let mut p = phi.clone();
                    p[k][v] += t;
                    evaluate(mesh, &mesh.positions, (&set, &p, false), plain, None)
                };
                let numeric = diff4(&at);
                assert!(
                    (d[v] - numeric).abs() <= 1e-6 * numeric.abs() + 1e-8,
                    "species {k}, vertex {v}: analytic {}, numeric {numeric}",
                    d[v]
                );
            }
        }
    }

    #[test]
    fn shape_and_field_derivatives_match_finite_differences_on_a_closed_mesh() {
        let mesh = perturbed_icosphere(1, 7);
        check(&mesh, None, Hold::Fraction, 1);
        check(&mesh, None, Hold::Amount, 2);
    }

    #[test]
    fn shape_and_field_derivatives_match_finite_differences_on_open_meshes() {
        for mesh in perturbed_patches(11) {
            // The rims: the vertices of edges with one face.
            let mut uses = std::collections::HashMap::new();
            for f in &mesh.faces {
                for k in 0..3 {
                    let (a, b) = (f[k], f[(k + 1) % 3]);
                    *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                }
            }
            let mut boundary = vec![false; mesh.vertex_count()];
            for ((a, b), _) in uses.into_iter().filter(|(_, c)| *c == 1) {
                boundary[a as usize] = true;
                boundary[b as usize] = true;
            }
            assert!(boundary.iter().any(|b| *b));
            check(&mesh, Some(&boundary), Hold::Fraction, 3);
            check(&mesh, Some(&boundary), Hold::Amount, 4);
        }
    }

    #[test]
    fn without_coupling_one_species_has_the_lattice_gas_entropy() {
        let mesh = perturbed_icosphere(1, 5);
        let n = mesh.vertex_count();
        let mut set = two_species();
        set.species.truncate(1);
        set.interactions.clear();
        let sp = &mut set.species[0];
        (sp.binding_energy, sp.gradient_energy) = (0.0, 0.0);
        (sp.curvature_coupling, sp.rigidity_change) = (0.0, 0.0);
        let area: f64 = geometry_at(&mesh, &mesh.positions).1.iter().sum();
        let phi = vec![vec![0.3; n]];
        let plain = (None, Hold::Fraction);
        let e = evaluate(&mesh, &mesh.positions, (&set, &phi, false), plain, None);
        // (k_BT/a_p)[φ ln φ + (1−φ) ln(1−φ)] per area.
        let per_area = 0.1 / 0.05 * (0.3 * 0.3f64.ln() + 0.7 * 0.7f64.ln());
        assert!((e - area * per_area).abs() <= 1e-12 * e.abs(), "{e}");
    }
}
