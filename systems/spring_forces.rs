//! External spring forces from fixed control points.
//!
//! Stage: Forces. Reads: positions, topology (1-rings), [`ControlPoint`]
//! entities. Writes: force accumulator. Units: k_ex in Ē/l̄². Each control
//! point pulls its nearest vertex (re-chosen on every evaluation) and that
//! vertex's 1-ring: each toward the point itself (as run) or, with the
//! centroid coupling, the patch's centroid toward the point.

use crate::energy::springs::control_point_springs;
use crate::engine::force::{FlipProposal, ForceContext, ForceKind, ForceTerm};
use crate::mesh::cell_list::CellList;
use crate::mesh::components::ControlPoint;
use crate::params::SpringCoupling;
use glam::DVec3;

/// Cell size of the nearest-vertex grid (l̄): two mean edge lengths, a few
/// vertices per cell on the surface.
const NEAREST_CELL_SIZE: f64 = 2.0;

/// The control-point spring system. Control points are read from the world
/// on each evaluation (a handful of entities, not a per-edge loop).
#[derive(Default)]
pub struct SpringForces {
    coupling: SpringCoupling,
    points: Vec<ControlPoint>,
    /// Each point's nearest vertex, kept as the next search's first guess.
    nearest: Vec<usize>,
    cells: CellList,
}

impl SpringForces {
    /// Springs with the given coupling.
    pub fn new(coupling: SpringCoupling) -> Self {
        Self {
            coupling,
            ..Default::default()
        }
    }

    /// Gathers the control points, returns the spring energy and, with
    /// `force`, adds the spring forces.
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        self.points.clear();
        self.points
            .extend(ctx.world.query::<&ControlPoint>().iter().copied());
        let p = ctx.positions;
        // Nearest vertices through a cell list (exactly the brute-force
        // answer): O(N) to build plus a few cells per point, instead of
        // O(N) per point.
        self.cells.build(p, NEAREST_CELL_SIZE);
        self.nearest.resize(self.points.len(), 0);
        for (cp, guess) in self.points.iter().zip(self.nearest.iter_mut()) {
            let start = if *guess < p.len() { *guess } else { 0 };
            *guess = self.cells.nearest(p, cp.position, start);
        }
        let (t, points, nearest) = (ctx.topology, &self.points, &self.nearest);
        control_point_springs(p, t, points, nearest, self.coupling, force)
    }
}

impl ForceTerm for SpringForces {
    fn name(&self) -> &str {
        "springs"
    }

    fn kind(&self) -> ForceKind {
        ForceKind::External
    }

    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        self.evaluate(ctx, None)
    }

    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        self.evaluate(ctx, Some(force))
    }

    /// Zero: the springs act on each point's nearest vertex and its 1-ring,
    /// and a flip changes the 1-rings of its four vertices only, so the
    /// flip system, while springs act, never flips at a point's nearest
    /// vertex (nearest vertices depend on positions alone, so the rule is
    /// the same both ways).
    fn flip_energy_change(&mut self, _: &FlipProposal<'_>) -> Option<f64> {
        Some(0.0)
    }
}
