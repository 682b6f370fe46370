//! Returns the positions to the exact constraints' surface after a step
//! ([`remembrane_core::constraint::project`]): Gauss-Newton steps along ∇A and ∇V
//! (smoothed over 1-rings), or along the directions a preconditioned
//! minimiser publishes in [`ProjectionDirections`] (its metric's P⁻¹∇A,
//! P⁻¹∇V), none moving a vertex by more than `max_correction`.
//!
//! Stage: Integrate (after the integrator). Reads: [`Constraints`], the
//! total force in [`ForceBuffers`] (written back with the positions),
//! [`StopRequest`] (a run that has asked to stop is not moved), [`Clock`]
//! (for errors). Writes: [`DensePositions`] and the world's positions (in
//! [`Membrane`]). A non-finite position stops the run with a blow-up error
//! naming the vertex.

use remembrane_core::constraint::{
    Constraints, Directions, ProjectionDirections, ProjectionScratch, project,
};
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
        Option<Res<'a, ProjectionDirections>>,
        ResMut<'a, DensePositions>,
        ResMut<'a, Membrane>,
    );

    fn name(&self) -> &str {
        "constraint_projection"
    }

    fn run(
        &mut self,
        (constraints, buffers, stop, clock, given, mut positions, mut membrane): Self::Data<'_>,
    ) -> Result<(), SimError> {
        if stop.0.is_some() {
            return Ok(());
        }
        let topology = membrane.cached_topology();
        let (targets, cap) = (constraints.targets, constraints.max_correction);
        let directions = match given
            .as_deref()
            .filter(|d| !d.0[0].is_empty() || !d.0[1].is_empty())
        {
            Some(ProjectionDirections([a, v])) => Directions::Given([a, v]),
            None => Directions::Smoothed(constraints.smoothing),
        };
        let done = project(
            &mut positions.0,
            topology,
            targets,
            cap,
            directions,
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
