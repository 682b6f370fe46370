//! Volume-penalty forces, E_V = k (V − V_t)² / V_t.
//!
//! Stage: Forces (penalty: 1-ring smoothed by the force stage). Reads:
//! positions, topology (faces). Writes: force accumulator. Units: k in
//! Ē/l̄³, V_t in l̄³.

use crate::energy::penalty::volume_penalty;
use crate::engine::force::{FlipProposal, ForceContext, ForceKind, ForceTerm};
use crate::engine::simulation::{Plugin, SimBuilder};
use crate::params::Target;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Volume penalty E_V = k (V − V_t)² / V_t (osmotic pressure).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeParams {
    /// k_V, penalty strength (Ē/l̄³; default 4).
    #[serde(
        default = "default_k_volume",
        deserialize_with = "crate::util::validate::non_negative"
    )]
    pub k: f64,
    /// V_t, target volume (l̄³ or fraction of the initial volume).
    pub target: Target,
}

pub(super) fn default_k_volume() -> f64 {
    4.0
}

/// The volume-penalty force system with a resolved target volume.
pub struct VolumeForces {
    /// Penalty strength k_V (Ē/l̄³).
    pub k: f64,
    /// Target volume V_t (l̄³).
    pub target: f64,
    gradient: Vec<DVec3>,
}

impl VolumeForces {
    /// A volume penalty with strength `k` (Ē/l̄³) and target `target` (l̄³).
    pub fn new(k: f64, target: f64) -> Self {
        Self {
            k,
            target,
            gradient: Vec::new(),
        }
    }
}

impl VolumeForces {
    /// The energy (Ē), and with `force` its negative gradient added to it
    /// (Ē/l̄).
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        volume_penalty(
            ctx.positions,
            &ctx.topology.faces,
            self.k,
            self.target,
            &mut self.gradient,
            force,
        )
    }
}

impl ForceTerm for VolumeForces {
    fn name(&self) -> &str {
        "volume"
    }

    fn kind(&self) -> ForceKind {
        ForceKind::Penalty
    }

    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        self.evaluate(ctx, None)
    }

    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        self.evaluate(ctx, Some(force))
    }

    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        let (x, dx) = (proposal.totals.volume, proposal.change.volume);
        let target = self.target;
        Some(self.k * ((x + dx - target).powi(2) - (x - target).powi(2)) / target)
    }
}

/// The volume penalty, its target resolved against the initial volume.
pub fn plugin(params: VolumeParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        let target = params.target.resolve(b.initial_state("Volume")?.volume);
        b.add_force_term(VolumeForces::new(params.k, target))?;
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for VolumeParams {
    /// Refused on open meshes: there is no enclosed volume without a
    /// closing reference, which is not implemented yet.
    fn open_mesh_support(&self) -> Result<(), String> {
        Err(
            "an open mesh encloses no volume (a closing reference such as a base plane \
             is not implemented yet)"
                .into(),
        )
    }

    fn add_to(
        &self,
        builder: &mut SimBuilder,
        _context: &crate::energy::builtin::TermContext,
    ) -> Result<(), crate::engine::error::BuildError> {
        builder.add_plugin(plugin(*self))?;
        Ok(())
    }
}
