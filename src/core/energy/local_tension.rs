//! Density-dependent local tension, E_a = k Σ_i (A_i/ρ_i − a0)² / a0.
//!
//! Stage: Forces (penalty: 1-ring smoothed by the force stage). Reads:
//! positions, lipid density, topology (faces). Writes: force accumulator.
//! Units: k in Ē/l̄², a0 in l̄² (a0 = A_t / N_initial, fixed at scene build).

use crate::energy::penalty::{LocalTensionScratch, local_tension};
use crate::engine::force::{ForceContext, ForceKind, ForceTerm};
use crate::engine::simulation::{Plugin, SimBuilder};
use crate::params::Target;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Density-dependent local tension E_a = k Σ_i (A_i/ρ_i − a0)² / a0 with
/// a0 = A_t / N_initial. Requires lipid density.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LocalTensionParams {
    /// k_a, strength (Ē/l̄²; default 12).
    #[serde(
        default = "default_k_local",
        deserialize_with = "crate::util::validate::non_negative"
    )]
    pub k: f64,
    /// A_t, total target area from which a0 = A_t / N_initial (l̄² or
    /// fraction of the initial area; the reservoir condition uses 733).
    pub target_area: Target,
}

pub(super) fn default_k_local() -> f64 {
    12.0
}

/// The local-tension force system.
pub struct LocalTensionForces {
    /// Strength k_a (Ē/l̄²).
    pub k: f64,
    /// Target area per vertex a0 (l̄²).
    pub a0: f64,
    scratch: LocalTensionScratch,
}

impl LocalTensionForces {
    /// A local-tension system with strength `k` and per-vertex target `a0`.
    pub fn new(k: f64, a0: f64) -> Self {
        Self {
            k,
            a0,
            scratch: LocalTensionScratch::default(),
        }
    }
}

impl ForceTerm for LocalTensionForces {
    fn name(&self) -> &str {
        "local_tension"
    }

    fn kind(&self) -> ForceKind {
        ForceKind::Penalty
    }

    fn uses_face_geometry(&self) -> bool {
        true
    }

    /// The energy (Ē), and with `force` its negative gradient added to it
    /// (Ē/l̄).
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        local_tension(
            &ctx.topology.faces,
            ctx.face_geometry,
            ctx.lipid,
            self.k,
            self.a0,
            &mut self.scratch,
            force,
        )
    }
}

/// Density-dependent local tension with a0 = A_t / Σρ: A_t / N_initial for a
/// fresh mesh (ρ = 1), and the same lipid unit after remeshing or when
/// starting from a saved state (Σρ is conserved).
pub fn plugin(params: LocalTensionParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        let init = b.initial_state("LocalTension")?;
        let a0 = params.target_area.resolve(init.area) / init.lipid_total;
        b.add_force_term(LocalTensionForces::new(params.k, a0))?;
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for LocalTensionParams {
    /// Correct on open meshes: a sum over vertices of their mixed areas, made of their faces' shares: a boundary vertex's is the share of its fan.
    const CORRECT_ON_OPEN_MESHES: bool = true;

    fn plugin(&self, _context: crate::energy::builtin::TermContext) -> impl Plugin {
        plugin(*self)
    }

    /// It reads the lipid density, which the fluid model cannot carry.
    fn needs(&self) -> crate::energy::builtin::TermNeeds {
        crate::energy::builtin::TermNeeds {
            lipid_density: true,
            not_in_fluid_model: Some((
                "",
                "LocalTension reads the lipid density carried by the vertices, and in the fluid \
                 model vertices slide within the membrane, so that density is no longer a field \
                 of the lipids (it would need remapping). Use Tension(sigma) or the `area` \
                 constraint, or the paper's model"
                    .into(),
            )),
            ..Default::default()
        }
    }
}
