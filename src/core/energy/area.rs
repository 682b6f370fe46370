//! Area-penalty forces, E_A = k (A − A_t)² / A_t.
//!
//! Stage: Forces (penalty: 1-ring smoothed by the force stage). Reads:
//! positions, topology (faces). Writes: force accumulator. Units: k in
//! Ē/l̄², A_t in l̄².

use crate::energy::penalty::area_penalty;
use crate::engine::force::{FlipProposal, ForceContext, ForceKind, ForceTerm};
use crate::engine::simulation::{Plugin, SimBuilder};
use crate::params::Target;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Area penalty E_A = k (A − A_t)² / A_t (global tension).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AreaParams {
    /// k_A, penalty strength (Ē/l̄²; default 8).
    #[serde(
        default = "default_k_area",
        deserialize_with = "crate::util::validate::non_negative"
    )]
    pub k: f64,
    /// A_t, target area (l̄² or fraction of the initial area).
    pub target: Target,
}

pub(super) fn default_k_area() -> f64 {
    8.0
}

/// The area-penalty force system with a resolved target area.
pub struct AreaForces {
    /// Penalty strength k_A (Ē/l̄²).
    pub k: f64,
    /// Target area A_t (l̄²).
    pub target: f64,
    gradient: Vec<DVec3>,
}

impl AreaForces {
    /// A area penalty with strength `k` (Ē/l̄²) and target `target` (l̄²).
    pub fn new(k: f64, target: f64) -> Self {
        Self {
            k,
            target,
            gradient: Vec::new(),
        }
    }
}

impl ForceTerm for AreaForces {
    fn name(&self) -> &str {
        "area"
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
        area_penalty(
            &ctx.topology.faces,
            ctx.face_geometry,
            self.k,
            self.target,
            &mut self.gradient,
            force,
        )
    }

    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        let (x, dx) = (proposal.totals.area, proposal.change.area);
        let target = self.target;
        Some(self.k * ((x + dx - target).powi(2) - (x - target).powi(2)) / target)
    }
}

/// The area penalty, its target resolved against the initial area.
pub fn plugin(params: AreaParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        let target = params.target.resolve(b.initial_state("Area")?.area);
        b.add_force_term(AreaForces::new(params.k, target))?;
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for AreaParams {
    /// Correct on open meshes: a sum over faces of their area: nothing in it assumes a closed surface.
    const CORRECT_ON_OPEN_MESHES: bool = true;

    fn plugin(&self, _context: crate::energy::builtin::TermContext) -> impl Plugin {
        plugin(*self)
    }

    /// A penalty on the area.
    fn needs(&self) -> crate::energy::builtin::TermNeeds {
        crate::energy::builtin::TermNeeds {
            penalises: Some(crate::energy::builtin::GlobalQuantity::Area),
            ..Default::default()
        }
    }
}
