//! Measures every edge once per tick for V_in: its vector, length and
//! segment ([`VinEdgeSamples`]), read by the V_in force and the time-step
//! rule instead of each gathering the end positions, taking the square root
//! and looking up the segment again.
//!
//! Stage: Gather (after `gather_state`). Reads: [`Membrane`] (edges),
//! [`DensePositions`], [`VinSegmentation`]. Writes: [`VinEdgeSamples`].

use remembrane_core::energy::vin::VinEdgeSamples;
use remembrane_core::energy::vin::VinSegmentation;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{DensePositions, SimError};
use remembrane_core::mesh::membrane::Membrane;

/// The edge-sampling system.
pub struct VinEdgeSampling;

/// Its name.
pub const VIN_EDGE_SAMPLES: &str = "vin_edge_samples";

impl System for VinEdgeSampling {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, VinSegmentation>,
        ResMut<'a, VinEdgeSamples>,
    );

    fn name(&self) -> &str {
        VIN_EDGE_SAMPLES
    }

    fn run(
        &mut self,
        (membrane, positions, segmentation, mut samples): Self::Data<'_>,
    ) -> Result<(), SimError> {
        samples.measure(
            &segmentation.0,
            &membrane.cached_topology().edges,
            &positions.0,
        );
        Ok(())
    }
}
