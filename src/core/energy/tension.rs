//! Constant surface tension, E_σ = σ A with A = Σ face areas.
//!
//! Unlike the area penalty, whose tension 2 k_A (A − A_t)/A_t follows the
//! area, σ here is a fixed parameter: the membrane is in contact with a lipid
//! reservoir at tension σ (the setting of the tether-pulling theory,
//! Derényi, Jülicher & Prost, PRL 88, 238101 (2002)).
//!
//! ## The force term
//!
//! Constant surface-tension forces, E_σ = σ A.
//!
//! Stage: Forces (conservative: used exactly, never smoothed). Reads:
//! topology (faces), face geometry. Writes: force accumulator. Units: σ in
//! Ē/l̄².

use crate::engine::force::{FlipProposal, ForceContext, ForceTerm};
use crate::engine::simulation::{Plugin, SimBuilder};
use crate::mesh::geometry::Corners;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Tension energy σA from the faces' precomputed geometry; with `force`,
/// adds −σ∇A.
pub fn surface_tension(
    faces: &[[u32; 3]],
    geometry: &[Corners],
    sigma: f64,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let twice_area: f64 = geometry.iter().map(|c| c.twice_area).sum();
    let energy = sigma * 0.5 * twice_area;
    if let Some(force) = force {
        // ∂(2A_f)/∂p_k = n̂ × e_k with e_k the edge opposite corner k.
        let half_sigma = 0.5 * sigma;
        for (f, c) in faces.iter().zip(geometry) {
            for k in 0..3 {
                force[f[k] as usize] -= half_sigma * c.n_hat.cross(c.e[k]);
            }
        }
    }
    energy
}

/// Constant surface tension E_σ = σ A: the membrane exchanges area with a
/// reservoir at tension σ (tether pulling; no target area).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TensionParams {
    /// σ, surface tension (Ē/l̄² = 10 k_BT/µm²; ≥ 0). A tube pulled from
    /// such a membrane has radius √(κ/2σ) and force 2π√(2σκ).
    #[serde(deserialize_with = "crate::util::validate::non_negative")]
    pub sigma: f64,
}

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

    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        surface_tension(&ctx.topology.faces, ctx.face_geometry, self.sigma, force)
    }

    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        Some(self.sigma * proposal.change.area)
    }
}

/// Constant surface tension σA.
pub fn plugin(params: crate::params::TensionParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        b.add_force_term(crate::energy::tension::TensionForces::new(params.sigma))?;
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for TensionParams {
    /// Correct on open meshes: σ times a sum over faces of their area: nothing in it assumes a closed surface.
    const CORRECT_ON_OPEN_MESHES: bool = true;

    fn plugin(&self, _context: crate::energy::builtin::TermContext) -> impl Plugin {
        plugin(*self)
    }
}
