//! The species' force term: their free energy
//! ([`crate::species::free_energy`]) at the proteins' current amounts, and
//! the shape force at fixed amounts (the surface carries its proteins: as
//! a vertex area grows, its fractions dilute).
//!
//! Reads the dense amounts [`SpeciesAmounts`] from the term inputs (the
//! `species_gather` system refreshes them each tick), or from the world
//! outside the schedule (finite differences, flip proposals); and, where the
//! relaxation has published the surface's measure at the same positions
//! ([`MeasuredSurface`]), that measure instead of measuring again, and its
//! last evaluation of the fields where it is of the same amounts
//! ([`Evaluated`]: the fractions it ended on, which differ from the
//! amounts' by round-off, and the local energies there).

use crate::energy::bending_measure::{MeasuredSurface, Surface, vertex_areas};
use crate::engine::force::{ForceContext, ForceTerm};
use crate::species::free_energy::{
    BaseBending, Derivatives, Evaluated, Fields, FreeEnergyScratch, Hold, free_energy_on,
};
use crate::species::params::SpeciesSet;
use crate::species::state::SpeciesAmounts;
use glam::DVec3;

/// The species term.
pub struct SpeciesForces {
    set: SpeciesSet,
    base: BaseBending,
    scratch: FreeEnergyScratch,
    amounts: SpeciesAmounts,
    dphi: Vec<Vec<f64>>,
    boundary: Vec<bool>,
}

impl SpeciesForces {
    /// The term of the species `set` on a membrane of bending `base`.
    pub fn new(set: SpeciesSet, base: BaseBending) -> Self {
        Self {
            set,
            base,
            scratch: FreeEnergyScratch::default(),
            amounts: SpeciesAmounts::default(),
            dphi: Vec::new(),
            boundary: Vec::new(),
        }
    }
}

impl ForceTerm for SpeciesForces {
    fn name(&self) -> &str {
        "species"
    }

    fn uses_face_geometry(&self) -> bool {
        true
    }

    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        let t = ctx.topology;
        let n = ctx.positions.len();
        let amounts = match ctx.inputs.get::<SpeciesAmounts>() {
            Some(a) if a.0.first().is_some_and(|x| x.len() == n) => a,
            _ => {
                self.amounts.gather(ctx.world, t, self.set.species.len());
                &self.amounts
            }
        };
        self.dphi.resize(self.set.species.len(), Vec::new());
        let out = force.map(|f| Derivatives {
            force: f,
            phi: &mut self.dphi,
        });
        let surface = Surface::new(ctx.positions, t, ctx.face_geometry, &mut self.boundary);
        // The relaxation's measure of these positions, where it has
        // published one.
        let measured = ctx
            .inputs
            .get::<MeasuredSurface>()
            .filter(|m| m.is_of(ctx.positions, t.epoch, self.base.discretisation))
            .map(|m| &m.terms);
        // And its last evaluation of the fields, where it is of these
        // amounts (to the bit) on that measure.
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        };
        let fields = match ctx.inputs.get::<Evaluated>() {
            Some(e)
                if measured.is_some()
                    && e.amounts.len() == amounts.0.len()
                    && e.amounts.iter().zip(&amounts.0).all(|(a, b)| same(a, b)) =>
            {
                Fields::Evaluated(e)
            }
            _ => Fields::Amounts(&amounts.0),
        };
        free_energy_on(
            surface,
            measured,
            self.base,
            &self.set,
            fields,
            Hold::Amount,
            &mut self.scratch,
            out,
        )
    }

    /// Every fraction at the amounts held stays inside (0, 1), and their
    /// sum below 1: a shape step that shrinks a full vertex's area past its
    /// proteins' leaves the free energy's domain.
    fn admits(&self, ctx: &ForceContext<'_>) -> bool {
        let t = ctx.topology;
        let n = ctx.positions.len();
        let species = self.set.species.len();
        let mut gathered = SpeciesAmounts::default();
        let amounts = match ctx.inputs.get::<SpeciesAmounts>() {
            Some(a) if a.0.first().is_some_and(|x| x.len() == n) => a,
            _ => {
                gathered.gather(ctx.world, t, species);
                &gathered
            }
        };
        // First a cheap sufficient test on a lower bound of every vertex
        // area: the barycentric third of each face (the dihedral form's area
        // itself). A mixed Voronoi area is at least 3/4 of it: every corner of
        // a face takes at least a quarter of it (an acute face's circumcentre
        // lies in its medial triangle).
        let mut bary = vec![0.0; n];
        for face in &t.faces {
            let [a, b, c] = face.map(|v| ctx.positions[v as usize]);
            let third = (b - a).cross(c - a).length() / 6.0;
            for &v in face {
                bary[v as usize] += third;
            }
        }
        let lower = match self.base.discretisation {
            crate::energy::bending::BendingDiscretisation::Dihedral => 1.0,
            crate::energy::bending::BendingDiscretisation::Cotangent => 0.75,
        };
        let inside = |areas: &[f64], scale: f64| {
            (0..n).all(|i| {
                let mut covered = 0.0;
                let all_positive = self.set.species.iter().zip(&amounts.0).all(|(s, a)| {
                    covered += s.area_per_protein * a[i];
                    a[i] > 0.0
                });
                all_positive && covered < scale * areas[i]
            })
        };
        if inside(&bary, lower) {
            return true;
        }
        let mut geometry = Vec::new();
        let geometry = match ctx.face_geometry.len() == t.faces.len() {
            true => ctx.face_geometry,
            false => {
                crate::mesh::geometry::face_geometry(ctx.positions, &t.faces, &mut geometry);
                &geometry[..]
            }
        };
        let areas = vertex_areas(&t.faces, geometry, n, self.base.discretisation);
        inside(&areas, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fd::{
        FdOptions, check_force_term, evaluate_with_inputs, perturbed_icosphere, perturbed_patches,
    };
    use crate::mesh::membrane::Membrane;
    use crate::species::params::Species;
    use crate::species::state::add_amounts;

    fn set() -> SpeciesSet {
        let sp = |name: &str, a: f64, c: f64, dk: f64, eta: f64| Species {
            curvature_coupling: c,
            rigidity_change: dk,
            binding_energy: -0.1,
            gradient_energy: eta,
            ..Species::new(name, a, crate::species::params::Initial::Fraction(0.1))
        };
        SpeciesSet {
            species: vec![
                sp("bar", 0.05, 1.5, 2.0, 0.7),
                sp("epsin", 0.02, -0.8, 0.0, 0.0),
            ],
            interactions: vec![],
            temperature: 0.1,
        }
    }

    /// The perturbed icosphere carrying amounts of both species (0.1-0.3 of
    /// the area), with its topology and faces' geometry.
    fn carrying() -> (
        crate::mesh::SurfaceMesh,
        Membrane,
        crate::mesh::topology::Topology,
        Vec<crate::mesh::geometry::Corners>,
    ) {
        let mesh = perturbed_icosphere(1, 3);
        let mut m = Membrane::from_mesh(&mesh, false).unwrap();
        add_amounts(&mut m, &set(), |k, slot, _| {
            (1.0 + (slot % 5) as f64) * [0.8, 2.0][k]
        })
        .unwrap();
        let t = m.topology().unwrap().clone();
        let mut geometry = Vec::new();
        crate::mesh::geometry::face_geometry(&mesh.positions, &t.faces, &mut geometry);
        (mesh, m, t, geometry)
    }

    /// With the relaxation's measure of the same positions published, the
    /// term's energy and force are the same to the bit as when it measures
    /// itself; a measure of other positions is not used. In both forms.
    #[test]
    fn a_published_measure_is_used_only_for_its_own_positions() {
        use crate::energy::bending_measure::VertexTerms;
        use crate::engine::term_inputs::TermInputs;
        use crate::mesh::geometry::face_geometry;
        let (mesh, m, t, geometry) = carrying();
        let moved: Vec<DVec3> = mesh.positions.iter().map(|p| *p * 1.01).collect();
        let mut moved_geometry = Vec::new();
        face_geometry(&moved, &t.faces, &mut moved_geometry);
        let bits = |(e, f): (f64, Vec<DVec3>)| {
            let mut b = vec![e.to_bits()];
            b.extend(f.iter().flat_map(|v| v.to_array().map(f64::to_bits)));
            b
        };
        for discretisation in [
            crate::energy::bending::BendingDiscretisation::Cotangent,
            crate::energy::bending::BendingDiscretisation::Dihedral,
        ] {
            let base = BaseBending {
                discretisation,
                kappa: 2.0,
                c0: 0.1,
            };
            let evaluate = |inputs: &TermInputs| {
                let mut term = SpeciesForces::new(set(), base);
                evaluate_with_inputs(&mut term, &m.world, &t, &mesh.positions, &geometry, inputs)
            };
            let measure = |positions: &[DVec3], geometry: &[crate::mesh::geometry::Corners]| {
                let mut rim = Vec::new();
                let mut terms = VertexTerms::default();
                terms.measure(
                    Surface::new(positions, &t, geometry, &mut rim),
                    discretisation,
                );
                let mut inputs = TermInputs::default();
                inputs.insert(MeasuredSurface {
                    positions: positions.to_vec(),
                    epoch: t.epoch,
                    terms,
                });
                inputs
            };
            let own = bits(evaluate(TermInputs::none()));
            assert_eq!(bits(evaluate(&measure(&mesh.positions, &geometry))), own);
            assert_eq!(bits(evaluate(&measure(&moved, &moved_geometry))), own);
            // Were the other positions' measure used, the energy would differ.
            let mut other = measure(&moved, &moved_geometry);
            other.get_mut::<MeasuredSurface>().unwrap().positions = mesh.positions.clone();
            assert_ne!(bits(evaluate(&other)), own);
        }
    }

    /// With the relaxation's last evaluation published for the same amounts
    /// (and its measure for the same positions), the term reads it instead of
    /// evaluating the fields again: the same energy and force but for
    /// round-off (the evaluation's fractions are the relaxation's, the
    /// amounts' differ from them in the last bits). An evaluation of other
    /// amounts is not used. In both forms.
    #[test]
    fn the_relaxations_last_evaluation_is_used_only_for_its_own_amounts() {
        use crate::energy::bending_measure::VertexTerms;
        use crate::engine::term_inputs::TermInputs;
        use crate::species::relax::{RelaxSettings, relax_amounts_measured};
        let (mesh, m, t, geometry) = carrying();
        for discretisation in [
            crate::energy::bending::BendingDiscretisation::Cotangent,
            crate::energy::bending::BendingDiscretisation::Dihedral,
        ] {
            let base = BaseBending {
                discretisation,
                kappa: 2.0,
                c0: 0.1,
            };
            let mut rim = Vec::new();
            let surface = Surface::new(&mesh.positions, &t, &geometry, &mut rim);
            let mut terms = VertexTerms::default();
            terms.measure(surface, discretisation);
            let mut amounts = SpeciesAmounts::default();
            amounts.gather(&m.world, &t, 2);
            let mut evaluated = Evaluated::default();
            let settings = RelaxSettings {
                tolerance: 1e-9,
                max_iterations: 100,
            };
            relax_amounts_measured(
                surface,
                &terms,
                base,
                &set(),
                &mut amounts.0,
                settings,
                Some(&mut evaluated),
            )
            .unwrap();
            evaluated.amounts = amounts.0.clone();
            let inputs = |evaluated: Option<Evaluated>| {
                let mut inputs = TermInputs::default();
                inputs.insert(amounts.clone());
                inputs.insert(MeasuredSurface {
                    positions: mesh.positions.clone(),
                    epoch: t.epoch,
                    terms: terms.clone(),
                });
                if let Some(e) = evaluated {
                    inputs.insert(e);
                }
                inputs
            };
            let evaluate = |inputs: &TermInputs| {
                let mut term = SpeciesForces::new(set(), base);
                evaluate_with_inputs(&mut term, &m.world, &t, &mesh.positions, &geometry, inputs)
            };
            let (e_own, f_own) = evaluate(&inputs(None));
            let (e_read, f_read) = evaluate(&inputs(Some(evaluated.clone())));
            let largest = f_own.iter().map(|f| f.length()).fold(0.0, f64::max);
            assert!(
                (e_read - e_own).abs() <= 1e-12 * e_own.abs(),
                "{e_read} against {e_own}"
            );
            for (a, b) in f_read.iter().zip(&f_own) {
                assert!((*a - *b).length() <= 1e-10 * largest, "{a} against {b}");
            }
            // A doctored evaluation of these amounts is read; of others, not.
            let mut doctored = evaluated.clone();
            doctored.local.f.iter_mut().for_each(|f| *f *= 2.0);
            let (e_doctored, _) = evaluate(&inputs(Some(doctored.clone())));
            assert!((e_doctored - e_own).abs() > 1e-3 * e_own.abs());
            doctored.amounts[1][0] *= 1.0 + 1e-15;
            let (e_other, f_other) = evaluate(&inputs(Some(doctored)));
            assert_eq!(e_other.to_bits(), e_own.to_bits());
            assert_eq!(f_other, f_own);
        }
    }

    /// The term's force, with the amounts read from the world, against
    /// fourth-order central differences of its energy at fixed amounts, on
    /// the perturbed icosphere and the open cap and disc.
    #[test]
    fn the_force_at_fixed_amounts_matches_finite_differences() {
        let mut meshes = vec![perturbed_icosphere(1, 3)];
        meshes.extend(perturbed_patches(9));
        for mesh in meshes {
            let mut m = Membrane::from_mesh(&mesh, false).unwrap();
            // 0.1-0.3 of the area at the start (vertex areas are ~0.4 l̄²).
            add_amounts(&mut m, &set(), |k, slot, _| {
                (1.0 + (slot % 5) as f64) * [0.8, 2.0][k]
            })
            .unwrap();
            let t = m.topology().unwrap().clone();
            let mut term = SpeciesForces::new(
                set(),
                BaseBending {
                    discretisation: Default::default(),
                    kappa: 2.0,
                    c0: 0.1,
                },
            );
            let options = FdOptions {
                step: 1e-5,
                ..FdOptions::default()
            };
            let report =
                check_force_term(&mut term, &m.world, &t, &mesh.positions, &[], None, options);
            assert!(report.passed(), "{report:?}");
        }
    }
}
