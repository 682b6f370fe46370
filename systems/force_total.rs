//! Checks every term's force for finiteness, sums the term buffers and
//! smooths the penalty forces.
//!
//! Stage: Forces (last; every registered term runs before it). Reads:
//! [`Membrane`] (1-rings for the smoothing), [`Clock`] (for errors).
//! Writes: the total in [`ForceBuffers`] (the Forces stage writes only the
//! force buffers; the world's `Force` components are written with the
//! positions by the integrator). Fails with a blow-up error naming the term
//! and vertex of the first non-finite force.

use remembrane_core::engine::force::{FORCE_TOTAL, ForceBuffers};
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{Clock, SimError};
use remembrane_core::mesh::membrane::Membrane;

/// The force-total system.
pub struct ForceTotal;

impl System for ForceTotal {
    type Data<'a> = (Res<'a, Membrane>, Res<'a, Clock>, ResMut<'a, ForceBuffers>);

    fn name(&self) -> &str {
        FORCE_TOTAL
    }

    fn run(&mut self, (membrane, clock, mut buffers): Self::Data<'_>) -> Result<(), SimError> {
        if let Some((term, vertex)) = buffers.first_non_finite() {
            let ev = &buffers.evaluation;
            let index = buffers
                .terms()
                .iter()
                .position(|t| t.name == term)
                .unwrap_or(0);
            let (element, value) = match vertex {
                Some(v) => (
                    format!("vertex {v}"),
                    format!("{:?}", ev.term_forces[index][v]),
                ),
                None => ("the energy".to_string(), format!("{}", ev.energies[index])),
            };
            return Err(SimError::BlowUp {
                iteration: clock.iteration + 1,
                quantity: "force",
                term: term.to_string(),
                element,
                value,
            });
        }
        buffers.finish(membrane.cached_topology());
        Ok(())
    }
}
