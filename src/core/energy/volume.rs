//! Volume-penalty forces, E_V = k (V − V_t)² / V_t.
//!
//! Stage: Forces (penalty: 1-ring smoothed by the force stage). Reads:
//! positions, topology (faces). Writes: force accumulator. Units: k in
//! Ē/l̄³, V_t in l̄³.
//!
//! V is the enclosed volume of a closed membrane. An open membrane encloses
//! none; with a closing plane (`closing: Plane(point, normal)`) V is the
//! volume between the membrane and the plane,
//! V = Σ_f h̄_f (A_f n̂_f · n), h̄_f the mean height of the face's corners
//! above the plane: the flux of ((x − p0)·n) n, whose divergence is 1,
//! through the membrane. The plane and the walls dropped from the rim onto
//! it carry no flux, so this is the volume of the region they close, for
//! any rim; on a closed membrane it is the enclosed volume for any plane.

use crate::energy::penalty::{volume_above_plane, volume_above_plane_penalty, volume_penalty};
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
    /// What closes an open membrane's volume (default none: the membrane
    /// must be closed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub closing: Option<VolumeClosing>,
}

/// The reference that closes an open membrane's volume.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum VolumeClosing {
    /// The plane through `point` (l̄) with `normal` (any non-zero vector,
    /// normalised): V is the volume between the membrane and the plane,
    /// positive where the membrane's normal points away from it.
    Plane {
        /// A point of the plane (l̄).
        point: (f64, f64, f64),
        /// The plane's normal.
        normal: (f64, f64, f64),
    },
}

impl VolumeClosing {
    /// The plane as (point, unit normal), or why it is invalid.
    pub fn plane(&self) -> Result<(DVec3, DVec3), crate::util::validate::ValidationError> {
        let VolumeClosing::Plane { point, normal } = *self;
        let p = DVec3::new(point.0, point.1, point.2);
        let n = DVec3::new(normal.0, normal.1, normal.2);
        let len = n.length();
        if !p.is_finite() || !len.is_finite() || len == 0.0 {
            return Err(
                "the closing plane needs a finite point and a finite, non-zero normal".into(),
            );
        }
        Ok((p, n / len))
    }
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
    /// The closing plane (point, unit normal), for an open membrane.
    closing: Option<(DVec3, DVec3)>,
    gradient: Vec<DVec3>,
}

impl VolumeForces {
    /// A volume penalty with strength `k` (Ē/l̄³) and target `target` (l̄³).
    pub fn new(k: f64, target: f64) -> Self {
        Self {
            k,
            target,
            closing: None,
            gradient: Vec::new(),
        }
    }

    /// The same on the volume between the membrane and the plane through
    /// `point` (l̄) with unit normal `normal`.
    pub fn closed_by_plane(k: f64, target: f64, point: DVec3, normal: DVec3) -> Self {
        Self {
            closing: Some((point, normal)),
            ..Self::new(k, target)
        }
    }
}

impl ForceTerm for VolumeForces {
    fn name(&self) -> &str {
        "volume"
    }

    fn kind(&self) -> ForceKind {
        ForceKind::Penalty
    }

    /// The energy (Ē), and with `force` its negative gradient added to it
    /// (Ē/l̄).
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        if let Some((point, normal)) = self.closing {
            return volume_above_plane_penalty(
                ctx.positions,
                &ctx.topology.faces,
                (point, normal),
                (self.k, self.target),
                &mut self.gradient,
                force,
            );
        }
        volume_penalty(
            ctx.positions,
            &ctx.topology.faces,
            self.k,
            self.target,
            &mut self.gradient,
            force,
        )
    }

    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        // The proposal's totals are the closed formula's: a closing plane's
        // volume is priced by whole evaluations.
        if self.closing.is_some() {
            return None;
        }
        let (x, dx) = (proposal.totals.volume, proposal.change.volume);
        let target = self.target;
        Some(self.k * ((x + dx - target).powi(2) - (x - target).powi(2)) / target)
    }
}

/// The volume penalty, its target resolved against the initial volume
/// (with a closing plane, the initial volume between membrane and plane,
/// which must be positive for a relative target).
pub fn plugin(params: VolumeParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        let invalid = |field: &str, reason: String| crate::engine::error::BuildError::Invalid {
            field: field.into(),
            reason,
        };
        let Some(closing) = params.closing else {
            let target = params.target.resolve(b.initial_state("Volume")?.volume);
            b.add_force_term(VolumeForces::new(params.k, target))?;
            return Ok(());
        };
        let (point, normal) = closing
            .plane()
            .map_err(|r| invalid("closing", r.to_string()))?;
        let membrane = b
            .resource_mut::<crate::mesh::membrane::Membrane>()
            .ok_or_else(|| invalid("", "no membrane".into()))?;
        let faces = membrane
            .topology()
            .map_err(|e| invalid("", e.to_string()))?
            .faces
            .clone();
        let mut positions = Vec::new();
        membrane.gather_positions(&mut positions);
        let initial = volume_above_plane(&positions, &faces, point, normal);
        let target = params.target.resolve(initial);
        if !(target > 0.0 && target.is_finite()) {
            return Err(invalid(
                "target",
                format!(
                    "the target volume must be positive (got {target} l̄³; the membrane \
                     starts with {initial} l̄³ above its closing plane)"
                ),
            ));
        }
        b.add_force_term(VolumeForces::closed_by_plane(
            params.k, target, point, normal,
        ))?;
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for VolumeParams {
    /// Correct on open meshes with a closing plane; refused without one.
    fn open_mesh_support(&self) -> Result<(), crate::energy::builtin::OpenMeshError> {
        match self.closing {
            Some(_) => Ok(()),
            None => Err(crate::energy::builtin::OpenMeshError::NoClosingPlane),
        }
    }

    fn plugin(&self, _context: crate::energy::builtin::TermContext) -> impl Plugin {
        plugin(*self)
    }

    /// A penalty on the enclosed volume.
    fn needs(&self) -> crate::energy::builtin::TermNeeds {
        crate::energy::builtin::TermNeeds {
            penalises: Some(crate::energy::builtin::GlobalQuantity::Volume),
            ..Default::default()
        }
    }
}
