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

use crate::energy::bending::BendingDiscretisation;
use crate::energy::bending_measure::{PullBackBuffers, Surface, VertexTerms};
use crate::mesh::geometry::Corners;
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
    /// The curvature the bending measures, which the coupling modifies.
    pub discretisation: BendingDiscretisation,
}

/// Reusable per-vertex buffers.
#[derive(Clone, Debug, Default)]
pub struct FreeEnergyScratch {
    terms: VertexTerms,
    buffers: PullBackBuffers,
    df_dh: Vec<f64>,
    g_area: Vec<f64>,
}

/// Where the derivatives go.
pub struct Derivatives<'a> {
    /// −∂F/∂r is added here (Ē/l̄), by dense slot.
    pub force: &'a mut [DVec3],
    /// ∂F/∂φ_s,i is written here (Ē), by species then dense slot.
    pub phi: &'a mut [Vec<f64>],
}

/// Each vertex's local energy per area f_i (Ē/l̄²) and its derivative
/// ∂f_i/∂h_i (Ē/l̄), as an evaluation of the free energy found them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LocalValues {
    /// f_i by dense slot.
    pub f: Vec<f64>,
    /// ∂f_i/∂h_i by dense slot (0 on a rim).
    pub df_dh: Vec<f64>,
}

/// An evaluation of the local free energy at some fractions, with what the
/// species term needs of it: the relaxation's last
/// ([`crate::species::relax::relax_amounts_measured`]), which the
/// relaxation system publishes in the term inputs so that the term,
/// evaluated next at the same positions and amounts, does not evaluate it
/// again ([`Fields::Evaluated`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Evaluated {
    /// The amounts these values stand for (by species, then dense slot):
    /// the term uses them only for these amounts, to the bit.
    pub amounts: Vec<Vec<f64>>,
    /// The fractions evaluated (by species, then dense slot).
    pub phi: Vec<Vec<f64>>,
    /// Each vertex's f_i and ∂f_i/∂h_i there.
    pub local: LocalValues,
    /// ∂F/∂φ_s,i there (Ē; the gradient energies' included).
    pub grad: Vec<Vec<f64>>,
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
    /// Fractions whose local energies and ∂F/∂φ were evaluated on the same
    /// measure (the relaxation's last evaluation): only the gradient
    /// energies' shape adjoints and the pull-back remain.
    Evaluated(&'a Evaluated),
}

/// The species' free energy (Ē) on `surface` for the `fields`, with the
/// curvature and the vertex areas in the discretisation of `base`
/// ([`crate::energy::bending_measure`]). A rim vertex of an open mesh carries no
/// bending (as in [`crate::energy::bending`]). With `out`, adds the shape
/// force to `out.force` under `hold` and writes ∂F/∂φ to `out.phi`.
pub fn free_energy(
    surface: Surface<'_>,
    base: BaseBending,
    set: &SpeciesSet,
    fields: Fields<'_>,
    hold: Hold,
    scratch: &mut FreeEnergyScratch,
    out: Option<Derivatives<'_>>,
) -> f64 {
    free_energy_on(surface, None, base, set, fields, hold, scratch, out)
}

/// [`free_energy`] on the surface's measure `measured` at `surface`'s
/// positions, in `base`'s discretisation (read, not measured again); with
/// `None`, measured.
#[allow(clippy::too_many_arguments)]
pub fn free_energy_on(
    surface: Surface<'_>,
    measured: Option<&VertexTerms>,
    base: BaseBending,
    set: &SpeciesSet,
    fields: Fields<'_>,
    hold: Hold,
    scratch: &mut FreeEnergyScratch,
    mut out: Option<Derivatives<'_>>,
) -> f64 {
    let FreeEnergyScratch {
        terms: own,
        buffers,
        df_dh: s_df_dh,
        g_area: s_g_area,
    } = scratch;
    let n = surface.vertex_count();
    let species = &set.species;
    let local = LocalEnergy::new(set, base);
    let terms: &VertexTerms = match measured {
        Some(terms) => terms,
        None => {
            own.measure(surface, base.discretisation);
            own
        }
    };
    let converted;
    let (phi, evaluated) = match fields {
        Fields::Fractions(phi) => (phi, None),
        Fields::Amounts(amounts) => {
            converted = crate::species::state::fractions(set, amounts, &terms.areas);
            (&converted[..], None)
        }
        Fields::Evaluated(e) => (&e.phi[..], Some(e)),
    };
    s_df_dh.clear();
    s_df_dh.resize(n, 0.0);
    s_g_area.clear();
    s_g_area.resize(n, 0.0);
    if let Some(o) = out.as_mut() {
        for (k, d) in o.phi.iter_mut().enumerate() {
            match evaluated {
                // ∂F/∂φ as evaluated, the gradient energies' included.
                Some(e) => d.clone_from(&e.grad[k]),
                None => {
                    d.clear();
                    d.resize(n, 0.0);
                }
            }
        }
    }
    let mut energy = 0.0;
    let mut at = [0.0; MAX_SPECIES];
    let mut dphi = [0.0; MAX_SPECIES];
    for i in 0..n {
        let a = terms.areas[i];
        let h = terms.curvature[i];
        let (f, df_dh) = match evaluated {
            Some(e) => (e.local.f[i], e.local.df_dh[i]),
            None => {
                for (k, p) in phi.iter().enumerate() {
                    at[k] = p[i];
                }
                // The coupled bending on interior vertices only.
                let interior = surface.is_interior(i);
                let (f, df_dh) = local.at(&at[..species.len()], interior.then_some(h), &mut dphi);
                if let Some(o) = out.as_mut() {
                    for (k, d) in dphi.iter().take(species.len()).enumerate() {
                        o.phi[k][i] = a * d;
                    }
                }
                (f, df_dh)
            }
        };
        s_df_dh[i] = df_dh;
        energy += a * f;
        // ∂(A f)/∂A at fixed h, less h f'(h) (h varies as 1/A; on a rim
        // both are 0).
        s_g_area[i] = f - df_dh * h;
    }
    // The gradient energies (their ∂/∂φ already in an evaluation's).
    let mut cot_adjoints = Vec::new();
    if set.has_gradient_energy() {
        cot_adjoints.resize(surface.faces().len(), [0.0; 3]);
        energy += gradient_energy(
            surface.faces(),
            surface.geometry,
            set,
            phi,
            out.as_mut()
                .filter(|_| evaluated.is_none())
                .map(|o| &mut *o.phi),
            Some(&mut cot_adjoints),
        );
    }
    let Some(o) = out else {
        return energy;
    };
    if hold == Hold::Amount {
        // φ_i = a_p n_i / A_i: ∂φ_i/∂A_i = −φ_i/A_i.
        for i in 0..n {
            let a = terms.areas[i];
            for (k, d) in o.phi.iter().enumerate() {
                s_g_area[i] -= d[i] * phi[k][i] / a;
            }
        }
    }
    terms.pull_back(surface, s_df_dh, s_g_area, &cot_adjoints, buffers, o.force);
    energy
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::bending_measure::vertex_areas;
    use crate::fd::{perturbed_icosphere, perturbed_patches};
    use crate::mesh::SurfaceMesh;
    use crate::mesh::geometry::face_geometry;
    use crate::mesh::topology::Topology;
    use crate::species::params::{Interaction, Species};
    use rand::{RngExt, SeedableRng};

    fn two_species() -> SpeciesSet {
        let sp = |name: &str, a: f64, c: f64, dk: f64, eps: f64, eta: f64| Species {
            curvature_coupling: c,
            rigidity_change: dk,
            binding_energy: eps,
            gradient_energy: eta,
            ..Species::new(name, a, crate::species::params::Initial::Fraction(0.1))
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

    /// A mesh to differentiate on: its topology (dense slots in the mesh's
    /// vertex order), its rims and the curvature's discretisation.
    struct Case<'a> {
        mesh: &'a SurfaceMesh,
        topology: Topology,
        boundary: Option<Vec<bool>>,
        form: BendingDiscretisation,
    }

    impl<'a> Case<'a> {
        fn new(mesh: &'a SurfaceMesh, open: bool, form: BendingDiscretisation) -> Self {
            let mut m = crate::mesh::membrane::Membrane::from_mesh(mesh, false).unwrap();
            let topology = m.topology().unwrap().clone();
            let boundary = open.then(|| topology.boundary_mask());
            if let Some(b) = &boundary {
                assert!(b.iter().any(|b| *b));
            }
            Self {
                mesh,
                topology,
                boundary,
                form,
            }
        }

        /// The faces' geometry at `positions` and the vertex areas.
        fn geometry_at(&self, positions: &[DVec3]) -> (Vec<Corners>, Vec<f64>) {
            let mut geometry = Vec::new();
            let faces = &self.topology.faces;
            face_geometry(positions, faces, &mut geometry);
            let areas = vertex_areas(faces, &geometry, positions.len(), self.form);
            (geometry, areas)
        }

        /// F at `positions` (κ = 5 Ē, C0 = 0.3/l̄) for the fractions `phi`,
        /// or, with `amounts`, for the fractions n_i / A_i of the amounts
        /// `phi` at these positions; with `out`, its derivatives.
        fn evaluate(
            &self,
            positions: &[DVec3],
            (set, phi, amounts): (&SpeciesSet, &[Vec<f64>], bool),
            hold: Hold,
            out: Option<Derivatives<'_>>,
        ) -> f64 {
            let (geometry, areas) = self.geometry_at(positions);
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
                discretisation: self.form,
            };
            let surface = Surface {
                positions,
                topology: &self.topology,
                geometry: &geometry,
                boundary: self.boundary.as_deref(),
            };
            let mut s = FreeEnergyScratch::default();
            free_energy(
                surface,
                base,
                set,
                Fields::Fractions(&phi),
                hold,
                &mut s,
                out,
            )
        }
    }

    /// Checks −∂F/∂r and ∂F/∂φ against central differences (fourth order)
    /// on `case`, holding fractions or amounts.
    fn check(case: &Case<'_>, hold: Hold, seed: u64) {
        let mesh = case.mesh;
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
        let e = case.evaluate(&mesh.positions, at_rest, hold, Some(derivatives));
        assert!(e.is_finite());
        let amounts = hold == Hold::Amount;
        // The held variables: the amounts A_i φ_i (a_p cancels).
        let held: Vec<Vec<f64>> = if amounts {
            let areas = case.geometry_at(&mesh.positions).1;
            phi.iter()
                .map(|p| p.iter().zip(&areas).map(|(p, a)| p * a).collect())
                .collect()
        } else {
            phi.clone()
        };
        // 1e-5 l̄: on the flat disc some |L_i| are small, and the curvature
        // h_i = s|L_i|/(2A_i) bends sharply at that scale (with 1e-4 the
        // stencil's truncation error reaches 1e-4 relative there).
        let h = 1e-5;
        let diff4 = |f: &dyn Fn(f64) -> f64| {
            (f(-2.0 * h) - 8.0 * f(-h) + 8.0 * f(h) - f(2.0 * h)) / (12.0 * h)
        };
        let form = case.form;
        for v in 0..n {
            let mut numeric = DVec3::ZERO;
            for c in 0..3 {
                let at = |t: f64| {
                    let mut p = mesh.positions.clone();
                    p[v][c] += t;
                    case.evaluate(&p, (&set, &held, amounts), Hold::Fraction, None)
                };
                numeric[c] = -diff4(&at);
            }
            let err = (force[v] - numeric).length();
            assert!(
                err <= 1e-6 * numeric.length() + 1e-8,
                "{form:?}, {hold:?}, vertex {v}: analytic {:?}, numeric {numeric:?}",
                force[v]
            );
        }
        for (k, d) in dphi.iter().enumerate() {
            for v in 0..n {
                let at = |t: f64| {
                    let mut p = phi.clone();
                    p[k][v] += t;
                    case.evaluate(&mesh.positions, (&set, &p, false), Hold::Fraction, None)
                };
                let numeric = diff4(&at);
                assert!(
                    (d[v] - numeric).abs() <= 1e-6 * numeric.abs() + 1e-8,
                    "{form:?}, species {k}, vertex {v}: analytic {}, numeric {numeric}",
                    d[v]
                );
            }
        }
    }

    const FORMS: [BendingDiscretisation; 2] = [
        BendingDiscretisation::Cotangent,
        BendingDiscretisation::Dihedral,
    ];

    #[test]
    fn shape_and_field_derivatives_match_finite_differences_on_a_closed_mesh() {
        let mesh = perturbed_icosphere(1, 7);
        for form in FORMS {
            let case = Case::new(&mesh, false, form);
            check(&case, Hold::Fraction, 1);
            check(&case, Hold::Amount, 2);
        }
    }

    #[test]
    fn shape_and_field_derivatives_match_finite_differences_on_open_meshes() {
        for mesh in perturbed_patches(11) {
            for form in FORMS {
                let case = Case::new(&mesh, true, form);
                check(&case, Hold::Fraction, 3);
                check(&case, Hold::Amount, 4);
            }
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
        let case = Case::new(&mesh, false, BendingDiscretisation::Cotangent);
        let area: f64 = case.geometry_at(&mesh.positions).1.iter().sum();
        let phi = vec![vec![0.3; n]];
        let e = case.evaluate(&mesh.positions, (&set, &phi, false), Hold::Fraction, None);
        // (k_BT/a_p)[φ ln φ + (1−φ) ln(1−φ)] per area.
        let per_area = 0.1 / 0.05 * (0.3 * 0.3f64.ln() + 0.7 * 0.7f64.ln());
        assert!((e - area * per_area).abs() <= 1e-12 * e.abs(), "{e}");
    }
}
