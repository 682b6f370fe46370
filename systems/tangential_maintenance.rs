//! The fluid model's force stage: mesh maintenance acts only in the
//! tangent planes ([`crate::fluid`]).
//!
//! Stage: Forces (after `force_terms`, before `force_total`). Reads:
//! [`VertexNormals`]. Writes: the buffers of the [`ForceKind::Maintenance`]
//! terms in [`ForceBuffers`] (each loses its component along the
//! area-weighted vertex normal, so the per-term forces reported are the
//! ones that act).

use crate::fluid::keep_tangential;
use crate::force::{FORCE_TOTAL, ForceBuffers, ForceKind};
use crate::force_term_system::FORCE_TERMS;
use crate::resources::{Res, ResMut};
use crate::schedule::System;
use crate::simulation::SimError;
use crate::systems::vertex_normals::VertexNormals;

/// Its name in the schedule.
pub const TANGENTIAL_MAINTENANCE: &str = "tangential_maintenance";

/// The tangential-maintenance system.
pub struct TangentialMaintenance;

impl TangentialMaintenance {
    /// Runs after every term and before their sum.
    pub const AFTER: &'static str = FORCE_TERMS;
    /// See [`Self::AFTER`].
    pub const BEFORE: &'static str = FORCE_TOTAL;
}

impl System for TangentialMaintenance {
    type Data<'a> = (Res<'a, VertexNormals>, ResMut<'a, ForceBuffers>);

    fn name(&self) -> &str {
        TANGENTIAL_MAINTENANCE
    }

    fn run(&mut self, (normals, mut buffers): Self::Data<'_>) -> Result<(), SimError> {
        let maintenance: Vec<usize> = (buffers.terms().iter().enumerate())
            .filter(|(_, t)| t.kind == ForceKind::Maintenance)
            .map(|(i, _)| i)
            .collect();
        for i in maintenance {
            keep_tangential(&mut buffers.evaluation.term_forces[i], &normals.0);
        }
        Ok(())
    }
}
