//! Line tension of an open membrane's free boundary loops:
//! E = Σ_loops λ_loop L_loop, L_loop = Σ_{e ∈ loop} ℓ_e, the energy of the
//! exposed lipid edge (λ in Ē/l̄ = 10 k_BT/µm ≈ 41 pN). The force on a rim
//! vertex is −λ times the sum of the unit vectors from its two loop
//! neighbours towards it: it pulls the rim straight and inwards.
//!
//! Declared per loop as a boundary condition, `Free(loop: 0,
//! line_tension: 0.1)` ([`crate::params::BoundaryCondition`]), and added by
//! the boundary-condition plugin, not in the list of built-in terms.
//!
//! ## The force term
//!
//! Stage: Forces (conservative). Reads: positions, topology (its boundary
//! loops, resolved again when the structure epoch changes). Writes: force
//! accumulator. Units: λ in Ē/l̄.

use crate::engine::force::{ForceContext, ForceTerm};
use crate::mesh::topology::Topology;
use glam::DVec3;

/// Line energy Σ λ_k ℓ_k over `edges` (vertex pairs, with their λ in Ē/l̄)
/// at `positions`; with `force`, adds −∇E.
pub fn line_energy(
    positions: &[DVec3],
    edges: &[([u32; 2], f64)],
    force: Option<&mut [DVec3]>,
) -> f64 {
    let mut energy = 0.0;
    match force {
        None => {
            for &([a, b], lambda) in edges {
                energy += lambda * positions[a as usize].distance(positions[b as usize]);
            }
        }
        Some(force) => {
            for &([a, b], lambda) in edges {
                let d = positions[b as usize] - positions[a as usize];
                let l = d.length();
                energy += lambda * l;
                // ∂ℓ/∂x_b = d/ℓ, ∂ℓ/∂x_a = −d/ℓ.
                let g = lambda * d / l;
                force[a as usize] += g;
                force[b as usize] -= g;
            }
        }
    }
    energy
}

/// The line-tension force term of the free loops.
///
/// A loop is declared by its index in the boundary loops' numbering of the
/// initial mesh ([`Topology::boundary_loops`]: by lowest vertex slot). An
/// edit can change that numbering on a membrane of several loops (a split
/// or merge moves a loop's lowest slot), so the term names each loop by
/// its vertices' entities after the first resolve: after a structure
/// change the loop is the current loop that holds any of its last vertices
/// (an edit changes one or two vertices of a loop, never all), and those
/// are the loop's vertices from then on. The entities are checkpointed
/// (a restored world keeps every entity's handle).
pub struct LineTensionForces {
    /// (loop index in the initial numbering, λ in Ē/l̄) of every free loop
    /// with a line tension.
    loops: Vec<(usize, f64)>,
    /// Each declared loop's vertex entities at the last resolve (`None`
    /// before the first; an empty list: the loop is gone).
    tracked: Option<Vec<Vec<hecs::Entity>>>,
    /// The loops' edges with their λ, for the topology of `edges_for`
    /// (structure epoch; vertex and edge counts).
    edges: Vec<([u32; 2], f64)>,
    edges_for: Option<(u64, usize, usize)>,
}

impl LineTensionForces {
    /// A line tension λ (Ē/l̄) on each `(loop index, λ)` of `loops` (loops
    /// as [`Topology::boundary_loops`] numbers them).
    pub fn new(loops: Vec<(usize, f64)>) -> Self {
        Self {
            loops,
            tracked: None,
            edges: Vec::new(),
            edges_for: None,
        }
    }

    /// Resolves the loops' edges for `topology` when its structure changed.
    fn resolve(&mut self, topology: &Topology) {
        let key = (
            topology.epoch,
            topology.vertex_count(),
            topology.edges.len(),
        );
        if self.edges_for == Some(key) {
            return;
        }
        self.edges_for = Some(key);
        self.edges.clear();
        let loops = topology.boundary_loops();
        let entities = |l: &[u32]| -> Vec<hecs::Entity> {
            l.iter()
                .map(|&v| topology.vertex_entities[v as usize])
                .collect()
        };
        let tracked = self.tracked.get_or_insert_with(|| {
            self.loops
                .iter()
                .map(|&(k, _)| loops.get(k).map_or_else(Vec::new, |l| entities(l)))
                .collect()
        });
        let owner: std::collections::HashMap<hecs::Entity, usize> = loops
            .iter()
            .enumerate()
            .flat_map(|(i, l)| entities(l).into_iter().map(move |e| (e, i)))
            .collect();
        for (vertices, &(_, lambda)) in tracked.iter_mut().zip(&self.loops) {
            let Some(&i) = vertices.iter().find_map(|e| owner.get(e)) else {
                vertices.clear();
                continue;
            };
            let l = &loops[i];
            for k in 0..l.len() {
                self.edges.push(([l[k], l[(k + 1) % l.len()]], lambda));
            }
            *vertices = entities(l);
        }
    }
}

impl ForceTerm for LineTensionForces {
    fn name(&self) -> &str {
        "line_tension"
    }

    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        self.resolve(ctx.topology);
        line_energy(ctx.positions, &self.edges, force)
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        let bits =
            |l: &Vec<hecs::Entity>| -> Vec<u64> { l.iter().map(|e| e.to_bits().get()).collect() };
        let tracked: Option<Vec<Vec<u64>>> =
            self.tracked.as_ref().map(|t| t.iter().map(bits).collect());
        Some(serde_json::json!({ "tracked": tracked }))
    }

    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError> {
        let tracked: Option<Vec<Vec<u64>>> =
            serde_json::from_value(state.get("tracked").cloned().ok_or("no `tracked`")?)?;
        self.tracked = match tracked {
            None => None,
            Some(t) if t.len() == self.loops.len() => Some(
                t.iter()
                    .map(|l| {
                        l.iter()
                            .map(|&b| hecs::Entity::from_bits(b).ok_or(format!("bad entity {b}")))
                            .collect::<Result<Vec<_>, _>>()
                    })
                    .collect::<Result<_, _>>()?,
            ),
            Some(t) => {
                return Err(format!(
                    "{} line-tension loops saved, the scene has {}",
                    t.len(),
                    self.loops.len()
                )
                .into());
            }
        };
        self.edges_for = None;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fd::{FdOptions, check_force_term, perturbed_patches};
    use crate::mesh::membrane::Membrane;

    #[test]
    fn force_matches_finite_differences_on_open_patches() {
        for mesh in perturbed_patches(7) {
            let mut membrane = Membrane::from_mesh(&mesh, false).unwrap();
            let t = membrane.topology().unwrap().clone();
            let mut pos = Vec::new();
            membrane.gather_positions(&mut pos);
            let mut term = LineTensionForces::new(vec![(0, 0.3)]);
            let options = FdOptions {
                rel_tol: 1e-6,
                abs_floor: 1e-9,
                ..FdOptions::default()
            };
            let report = check_force_term(&mut term, &membrane.world, &t, &pos, &[], None, options);
            assert!(report.max_force > 0.1, "{}", report.max_force);
            assert!(report.passed(), "{:?}", report.failures.first());
            // The energy is λ times the rim's length, and only rim vertices
            // feel the force.
            let rim = &t.boundary_loops()[0];
            let length: f64 = (0..rim.len())
                .map(|i| pos[rim[i] as usize].distance(pos[rim[(i + 1) % rim.len()] as usize]))
                .sum();
            let mut f = vec![DVec3::ZERO; pos.len()];
            let e = line_energy(&pos, &term.edges, Some(&mut f));
            assert!((e - 0.3 * length).abs() < 1e-12 * e);
            for (v, f) in f.iter().enumerate() {
                assert_eq!(f.length() > 0.0, rim.contains(&(v as u32)), "vertex {v}");
            }
            // A checkpoint keeps the loop's vertices: a restored term
            // resolves the same edges.
            let mut restored = LineTensionForces::new(vec![(0, 0.3)]);
            restored.restore_state(term.save_state().unwrap()).unwrap();
            assert_eq!(restored.tracked, term.tracked);
            restored.resolve(&t);
            assert_eq!(restored.edges, term.edges);
            let wrong = LineTensionForces::new(vec![(0, 0.3), (1, 0.1)])
                .restore_state(term.save_state().unwrap());
            assert!(wrong.is_err());
        }
    }
}
