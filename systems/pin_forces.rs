//! Pinned boundary loops (an open membrane's `Pinned` boundary condition):
//! their vertices keep their initial positions. This system and
//! `pin_positions` ([`crate::pin_positions`]) share the [`PinnedVertices`]
//! resource.
//!
//! [`PinForces`] (Forces, after `force_total`) zeroes the total force on
//! every pinned vertex, so the time step, the integrator's drift and the
//! minimiser see a membrane whose rim does not move. Reads
//! [`PinnedVertices`]. Writes the total force in [`ForceBuffers`] (the
//! energies keep every term's whole value).
//!
//! Vertices are named by dense slot: the topology of an open membrane does
//! not change (remeshing and flips are refused on it).

use glam::DVec3;
use remembrane_core::engine::force::ForceBuffers;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::SimError;

/// The pinned vertices (dense slots) and their fixed positions (l̄).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PinnedVertices {
    /// Dense slots of the pinned vertices.
    pub vertices: Vec<u32>,
    /// Their positions (l̄), in the same order.
    pub positions: Vec<DVec3>,
}

/// Name of [`PinForces`] in the schedule.
pub const PIN_FORCES: &str = "pin_forces";

/// Zeroes the total force on the pinned vertices.
pub struct PinForces;

impl System for PinForces {
    type Data<'a> = (Res<'a, PinnedVertices>, ResMut<'a, ForceBuffers>);

    fn name(&self) -> &str {
        PIN_FORCES
    }

    fn run(&mut self, (pinned, mut buffers): Self::Data<'_>) -> Result<(), SimError> {
        let total = &mut buffers.evaluation.total;
        for &v in &pinned.vertices {
            total[v as usize] = DVec3::ZERO;
        }
        Ok(())
    }
}
