//! [`PinPositions`] (Integrate, after the integrator) puts the held
//! vertices of an open membrane's `Pinned` and `Roller` loops back where
//! they were held (a roller's only along its direction), undoing the
//! thermal noise's move. Reads
//! [`PinnedVertices`] (see [`crate::pin_forces`]), the total force in
//! [`ForceBuffers`] (written back with the positions). Writes
//! [`DensePositions`] and the world's positions (in [`Membrane`]).

use remembrane_core::engine::force::ForceBuffers;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::shared_resources::PinnedVertices;
use remembrane_core::engine::simulation::{DensePositions, SimError};
use remembrane_core::mesh::membrane::Membrane;

/// Puts the held vertices back at their positions, in the held directions.
pub struct PinPositions;

impl System for PinPositions {
    type Data<'a> = (
        Res<'a, PinnedVertices>,
        Res<'a, ForceBuffers>,
        ResMut<'a, DensePositions>,
        ResMut<'a, Membrane>,
    );

    fn name(&self) -> &str {
        "pin_positions"
    }

    fn run(
        &mut self,
        (pinned, buffers, mut positions, mut membrane): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let mut moved = false;
        let held = pinned.positions.iter().zip(&pinned.held);
        for (&v, (&x, &h)) in pinned.vertices.iter().zip(held) {
            let p = &mut positions.0[v as usize];
            let back = h.restore(*p, x);
            moved |= *p != back;
            *p = back;
        }
        if moved {
            membrane.scatter_positions_and_forces(&positions.0, &buffers.evaluation.total);
        }
        Ok(())
    }
}
