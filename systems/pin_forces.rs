//! Held boundary loops (an open membrane's `Pinned` and `Roller` boundary
//! conditions): their vertices keep their initial positions, in every
//! direction (pinned) or along one (roller). This system and
//! `pin_positions` ([`crate::pin_positions`]) share the [`PinnedVertices`]
//! resource.
//!
//! [`PinForces`] (Forces, after `force_total`) removes the held part of the
//! total force on every held vertex (all of it when pinned), so the time step, the integrator's drift and the
//! minimiser see a membrane whose rim does not move. Reads
//! [`PinnedVertices`]. Writes the total force in [`ForceBuffers`] (the
//! energies keep every term's whole value).
//!
//! Vertices are named by entity, the source of truth kept through remesh
//! edits, and by dense slot, a cache of it: the remesh system
//! ([`crate::remesh`]) re-slots the cache after its edits, adds the new
//! vertex of a split held boundary edge and never merges a held vertex
//! away (flips are refused on open membranes).

use remembrane_core::engine::force::ForceBuffers;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::shared_resources::PinnedVertices;
use remembrane_core::engine::simulation::SimError;

/// Name of [`PinForces`] in the schedule.
pub const PIN_FORCES: &str = "pin_forces";

/// Removes the held part of the total force on the held vertices.
pub struct PinForces;

impl System for PinForces {
    type Data<'a> = (Res<'a, PinnedVertices>, ResMut<'a, ForceBuffers>);

    fn name(&self) -> &str {
        PIN_FORCES
    }

    fn run(&mut self, (pinned, mut buffers): Self::Data<'_>) -> Result<(), SimError> {
        let total = &mut buffers.evaluation.total;
        for (&v, &held) in pinned.vertices.iter().zip(&pinned.held) {
            let f = &mut total[v as usize];
            *f = held.release(*f);
        }
        Ok(())
    }
}
