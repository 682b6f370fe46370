//! Returns the positions to the exact constraints' surface after a step
//! ([`remembrane_core::constraint::project`]): Gauss-Newton steps along ∇A and ∇V,
//! none moving a vertex by more than `max_correction`.
//!
//! Stage: Integrate (after the integrator). Reads: [`Constraints`], the
//! total force in [`ForceBuffers`] (written back with the positions),
//! [`StopRequest`] (a run that has asked to stop is not moved), [`Clock`]
//! (for errors). Writes: [`DensePositions`] and the world's positions (in
//! [`Membrane`]). A non-finite position stops the run with a blow-up error
//! naming the vertex.

use remembrane_core::constraint::{Constraints, ProjectionScratch, project};
use remembrane_core::engine::force::ForceBuffers;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{Clock, DensePositions, SimError, StopRequest};
use remembrane_core::mesh::membrane::Membrane;

/// The constraint-projection system.
#[derive(Default)]
pub struct ConstraintProjection {
    scratch: ProjectionScratch,
}

impl System for ConstraintProjection {
    type Data<'a> = (
        Res<'a, Constraints>,
        Res<'a, ForceBuffers>,
        Res<'a, StopRequest>,
        Res<'a, Clock>,
        ResMut<'a, DensePositions>,
        ResMut<'a, Membrane>,
    );

    fn name(&self) -> &str {
        "constraint_projection"
    }

    fn run(
        &mut self,
        (constraints, buffers, stop, clock, mut positions, mut membrane): Self::Data<'_>,
    ) -> Result<(), SimError> {
        if stop.0.is_some() {
            return Ok(());
        }
        let done = project(
            &mut positions.0,
            membrane.cached_topology(),
            constraints.targets,
            constraints.max_correction,
            constraints.smoothing,
            &mut self.scratch,
        );
        if done.steps == 0 {
            return Ok(());
        }
        if let Some(v) = positions.0.iter().position(|p| !p.is_finite()) {
            return Err(SimError::BlowUp {
                iteration: clock.iteration,
                quantity: "position",
                term: "constraint_projection".into(),
                element: format!("vertex {v}"),
                value: format!("{:?}", positions.0[v]),
            });
        }
        membrane.scatter_positions_and_forces(&positions.0, &buffers.evaluation.total);
        Ok(())
    }
}
