//! External spring forces from fixed control points.
//!
//! Stage: Forces. Reads: positions, topology (1-rings), [`ControlPoint`]
//! entities. Writes: force accumulator. Units: k_ex in Ē/l̄². Each control
//! point pulls its nearest vertex (re-chosen on every evaluation) and that
//! vertex's 1-ring: each toward the point itself (as run) or, with the
//! centroid coupling, the patch's centroid toward the point.

use crate::components::ControlPoint;
use crate::energy::springs::control_point_springs;
use crate::force::{ForceContext, ForceTerm};
use crate::params::SpringCoupling;
use glam::DVec3;

/// The control-point spring system. Control points are read from the world
/// on each evaluation (a handful of entities, not a per-edge loop).
#[derive(Default)]
pub struct SpringForces {
    coupling: SpringCoupling,
    points: Vec<ControlPoint>,
}

impl SpringForces {
    /// Springs with the given coupling.
    pub fn new(coupling: SpringCoupling) -> Self {
        Self {
            coupling,
            points: Vec::new(),
        }
    }

    /// Gathers the control points, returns the spring energy and, with
    /// `force`, adds the spring forces.
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        self.points.clear();
        self.points
            .extend(ctx.world.query::<&ControlPoint>().iter().copied());
        let t = ctx.topology;
        control_point_springs(
            ctx.positions,
            &t.ring_offsets,
            &t.ring,
            &self.points,
            self.coupling,
            force,
        )
    }
}

impl ForceTerm for SpringForces {
    fn name(&self) -> &str {
        "springs"
    }

    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        self.evaluate(ctx, None)
    }

    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        self.evaluate(ctx, Some(force))
    }
}
