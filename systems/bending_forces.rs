//! Helfrich bending forces (analytic gradient of the cotangent energy).
//!
//! Stage: Forces. Reads: positions, topology (faces). Writes: force
//! accumulator. Units: κ in Ē, C0 in 1/l̄. See [`crate::energy::bending`].

use crate::energy::bending::{BendingScratch, bending};
use crate::force::{ForceContext, ForceTerm};
use crate::params::BendingParams;
use glam::DVec3;

/// The bending force system.
pub struct BendingForces {
    params: BendingParams,
    scratch: BendingScratch,
}

impl BendingForces {
    /// A bending system with the given modulus and spontaneous curvature.
    pub fn new(params: BendingParams) -> Self {
        Self {
            params,
            scratch: BendingScratch::default(),
        }
    }
}

impl ForceTerm for BendingForces {
    fn name(&self) -> &str {
        "bending"
    }

    fn uses_face_geometry(&self) -> bool {
        true
    }

    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        let p = &self.params;
        bending(
            ctx.positions.len(),
            &ctx.topology.faces,
            ctx.face_geometry,
            p.kappa,
            p.c0,
            &mut self.scratch,
            None,
        )
    }

    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        let p = &self.params;
        bending(
            ctx.positions.len(),
            &ctx.topology.faces,
            ctx.face_geometry,
            p.kappa,
            p.c0,
            &mut self.scratch,
            Some(force),
        )
    }
}
