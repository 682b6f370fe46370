//! Checks every term's force for finiteness, sums the term buffers and
//! smooths the penalty forces' sum over closed 1-rings (SPEC §2: as run, 4
//! passes; 0 = the exact gradient).
//!
//! Stage: Forces (last; every registered term runs before it). Reads:
//! [`Membrane`] (1-rings for the smoothing), [`Clock`] (for errors).
//! Writes: the total in [`ForceBuffers`] (the Forces stage writes only the
//! force buffers; the world's `Force` components are written with the
//! positions by the integrator). Fails with a blow-up error naming the term
//! and vertex of the first non-finite force.

use remembrane_core::energy::penalty::{SmoothingScratch, smooth_over_rings};
use remembrane_core::engine::force::{FORCE_TOTAL, ForceBuffers};
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{Clock, SimError};
use remembrane_core::mesh::membrane::Membrane;

/// The force-total system.
#[derive(Default)]
pub struct ForceTotal {
    /// Passes of closed 1-ring averaging of the penalty terms' forces.
    penalty_smoothing: u32,
    scratch: SmoothingScratch,
}

impl ForceTotal {
    /// Sums the terms, smoothing the penalty forces `penalty_smoothing` times.
    pub fn new(penalty_smoothing: u32) -> Self {
        Self {
            penalty_smoothing,
            scratch: SmoothingScratch::default(),
        }
    }
}

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
        let (topology, passes) = (membrane.cached_topology(), self.penalty_smoothing);
        buffers.finish(|penalty| smooth_over_rings(penalty, topology, passes, &mut self.scratch));
        Ok(())
    }
}
