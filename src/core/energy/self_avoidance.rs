//! Self-avoidance: a short-range repulsion between vertices that are not
//! 1-ring neighbours, so that two regions of the membrane pressed together
//! cannot pass through each other.
//!
//! E = Σ_{i<j, j ∉ ring(i), r_ij < d0} k (d0 − r_ij)³ / (3 d0), a cubic
//! overlap penalty: zero with its force and the force's derivative at
//! r = d0 (C², so finite differences and the integrator see no kink);
//! F_i = k (d0 − r_ij)² / d0 · r̂_ij pushes i away from j. Pairs are found with a uniform cell list of cell
//! size d0 (27 cells per vertex), visited in a fixed order (vertex slots,
//! then cells, then slots within a cell), so the sums are reproducible.
//!
//! ## The force term
//!
//! Self-avoidance forces (see [`crate::energy::self_avoidance`]).
//!
//! Stage: Forces. Reads: positions, topology (1-rings, excluded pairs).
//! Writes: force accumulator. Units: k in Ē/l̄², d0 in l̄.

use crate::engine::force::{ForceContext, ForceTerm};
use crate::engine::simulation::{Plugin, SimBuilder};
pub use crate::mesh::cell_list::CellList;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// The self-avoidance energy (Ē) with stiffness `k` (Ē/l̄²) and range `d0`
/// (l̄); with `force`, adds −∇E. `topology` gives the 1-rings
/// (CSR by vertex slot) whose pairs are excluded.
pub fn self_avoidance(
    positions: &[DVec3],
    topology: &crate::mesh::topology::Topology,
    k: f64,
    d0: f64,
    cells: &mut CellList,
    mut force: Option<&mut [DVec3]>,
) -> f64 {
    let n = positions.len();
    if n == 0 {
        return 0.0;
    }
    // Cells no smaller than d0, so the 27 cells around a vertex hold every
    // vertex within d0 of it.
    cells.build(positions, d0);
    let d0_sq = d0 * d0;
    let mut energy = 0.0;
    for (i, &p) in positions.iter().enumerate() {
        let c = cells.cell(p);
        let neighbours = topology.neighbours(i);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &j in cells.members(c, glam::IVec3::new(dx, dy, dz)) {
                        if j as usize <= i || neighbours.contains(&j) {
                            continue;
                        }
                        let d = p - positions[j as usize];
                        let r_sq = d.length_squared();
                        if r_sq >= d0_sq {
                            continue;
                        }
                        let r = r_sq.sqrt();
                        let overlap = d0 - r;
                        energy += k * overlap * overlap * overlap / (3.0 * d0);
                        if let Some(f) = force.as_deref_mut()
                            && r > 0.0
                        {
                            let push = d * (k * overlap * overlap / (d0 * r));
                            f[i] += push;
                            f[j as usize] -= push;
                        }
                    }
                }
            }
        }
    }
    energy
}

/// The same energy by checking every pair (O(N²); a reference for tests).
pub fn self_avoidance_brute_force(
    positions: &[DVec3],
    topology: &crate::mesh::topology::Topology,
    k: f64,
    d0: f64,
) -> f64 {
    let mut energy = 0.0;
    for i in 0..positions.len() {
        let neighbours = topology.neighbours(i);
        for j in i + 1..positions.len() {
            if neighbours.contains(&(j as u32)) {
                continue;
            }
            let r = positions[i].distance(positions[j]);
            if r < d0 {
                energy += k * (d0 - r).powi(3) / (3.0 * d0);
            }
        }
    }
    energy
}

/// Self-avoidance: a repulsion k(d0 − r)³/(3 d0) between vertices that are
/// not 1-ring neighbours and closer than d0.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SelfAvoidanceParams {
    /// k, stiffness of the repulsion (Ē/l̄²; default 500: at an overlap of
    /// 0.1 l̄ the pair energy is 0.28 Ē and the force 8.3 Ē/l̄; two vertices
    /// on top of each other cost 60 Ē).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub k: f64,
    /// d0, range of the repulsion (l̄; default 0.6: below the shortest edge
    /// the remesher lets live, 0.7, so no healthy mesh feels it between
    /// non-neighbours of its own patch).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub distance: f64,
}

impl Default for SelfAvoidanceParams {
    fn default() -> Self {
        Self {
            k: 500.0,
            distance: 0.6,
        }
    }
}

/// The self-avoidance force term.
pub struct SelfAvoidanceForces {
    params: SelfAvoidanceParams,
    cells: CellList,
}

impl SelfAvoidanceForces {
    /// A repulsion of stiffness `params.k` within `params.distance`.
    pub fn new(params: SelfAvoidanceParams) -> Self {
        Self {
            params,
            cells: CellList::default(),
        }
    }
}

impl ForceTerm for SelfAvoidanceForces {
    fn name(&self) -> &str {
        "self_avoidance"
    }

    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        let t = ctx.topology;
        self_avoidance(
            ctx.positions,
            t,
            self.params.k,
            self.params.distance,
            &mut self.cells,
            force,
        )
    }
}

/// Self-avoidance between non-neighbouring vertices.
pub fn plugin(params: crate::params::SelfAvoidanceParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        b.add_force_term(crate::energy::self_avoidance::SelfAvoidanceForces::new(
            params,
        ))?;
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for SelfAvoidanceParams {
    /// Correct on open meshes: pairs of vertices that are not ring neighbours: a boundary vertex's ring is its fan.
    const CORRECT_ON_OPEN_MESHES: bool = true;

    fn plugin(&self, _context: crate::energy::builtin::TermContext) -> impl Plugin {
        plugin(*self)
    }

    fn at_resolution(&mut self, h: f64) {
        self.distance *= h;
    }
}
