//! Self-avoidance forces (see [`crate::energy::self_avoidance`]).
//!
//! Stage: Forces. Reads: positions, topology (1-rings, excluded pairs).
//! Writes: force accumulator. Units: k in Ē/l̄², d0 in l̄.

use crate::energy::self_avoidance::{CellList, self_avoidance};
use crate::engine::force::{ForceContext, ForceTerm};
use crate::params::SelfAvoidanceParams;
use glam::DVec3;

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

impl ForceTerm for SelfAvoidanceForces {
    fn name(&self) -> &str {
        "self_avoidance"
    }

    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        self.evaluate(ctx, None)
    }

    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        self.evaluate(ctx, Some(force))
    }
}
