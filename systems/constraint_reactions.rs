//! Removes the exact constraints' reactions from the total force
//! ([`remembrane_core::constraint::remove_reactions`]): what is left moves the shape
//! without changing the held area and volume, and the multipliers are the
//! tension σ and pressure Δp that hold them.
//!
//! Stage: Forces (after `force_total`). Reads: [`Membrane`] (faces),
//! [`DensePositions`], [`Constraints`]. Writes: the total force,
//! `evaluation.constraint` and `evaluation.constraint_gradients` (the
//! gradients the minimiser then uses, measured once) in [`ForceBuffers`].

use remembrane_core::constraint::{ConstraintState, Constraints, remove_reactions};
use remembrane_core::engine::force::ForceBuffers;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{DensePositions, SimError};
use remembrane_core::mesh::membrane::Membrane;

/// The constraint-reaction system.
#[derive(Default)]
pub struct ConstraintReactions;

/// Its name in the schedule.
pub const CONSTRAINT_REACTIONS: &str = "constraint_reactions";

impl System for ConstraintReactions {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, Constraints>,
        ResMut<'a, ForceBuffers>,
    );

    fn name(&self) -> &str {
        CONSTRAINT_REACTIONS
    }

    fn run(
        &mut self,
        (membrane, positions, constraints, mut buffers): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let ev = &mut buffers.evaluation;
        let g = &mut ev.constraint_gradients;
        g.measure_on(&positions.0, membrane.cached_topology());
        let targets = constraints.targets;
        let reactions = remove_reactions(g, targets, &mut ev.total);
        ev.constraint = Some(ConstraintState {
            targets,
            area: g.area,
            volume: g.volume,
            reactions,
        });
        Ok(())
    }
}
