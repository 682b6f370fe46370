//! Constant surface-tension forces, E_σ = σ A.
//!
//! Stage: Forces (conservative: used exactly, never smoothed). Reads:
//! topology (faces), face geometry. Writes: force accumulator. Units: σ in
//! Ē/l̄².

use crate::energy::tension::surface_tension;
use crate::engine::force::{FlipProposal, ForceContext, ForceTerm};
use glam::DVec3;

/// The constant-tension force system.
pub struct TensionForces {
    /// σ, surface tension (Ē/l̄²).
    pub sigma: f64,
}

impl TensionForces {
    /// A tension term with σ = `sigma` (Ē/l̄²).
    pub fn new(sigma: f64) -> Self {
        Self { sigma }
    }
}

impl ForceTerm for TensionForces {
    fn name(&self) -> &str {
        "tension"
    }

    fn uses_face_geometry(&self) -> bool {
        true
    }

    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        surface_tension(&ctx.topology.faces, ctx.face_geometry, self.sigma, None)
    }

    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        surface_tension(
            &ctx.topology.faces,
            ctx.face_geometry,
            self.sigma,
            Some(force),
        )
    }

    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        Some(self.sigma * proposal.change.area)
    }
}
