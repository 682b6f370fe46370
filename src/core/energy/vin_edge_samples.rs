//! Every edge measured once per tick for V_in: its vector, length and
//! segment ([`VinEdgeSamples`]), read by the V_in force and the time-step
//! rule instead of each gathering the end positions, taking the square root
//! and looking up the segment again. The system that measures them
//! ([`VinEdgeSampling`]) is part of V_in's plugin ([`super::vin::plugin`]).
//!
//! Stage: Gather (after `gather_state`). Reads: [`Membrane`] (edges),
//! [`DensePositions`], [`VinSegmentation`]. Writes: [`VinEdgeSamples`].

use crate::energy::vin::{Segmentation, VinSegmentation};
use crate::engine::resources::{Res, ResMut};
use crate::engine::schedule::System;
use crate::engine::simulation::{DensePositions, SimError};
use crate::mesh::membrane::Membrane;
use glam::DVec3;

pub use crate::mesh::geometry::EdgeSample;

/// Every edge's [`EdgeSample`], in edge order, measured once per tick in
/// the Gather stage and shared by the V_in force and the time-step rule,
/// which would otherwise both gather the end positions, take the square
/// root and look up the segment (a resource of the vin plugin; empty until
/// measured).
#[derive(Clone, Debug, Default)]
pub struct VinEdgeSamples(pub Vec<EdgeSample>);

impl VinEdgeSamples {
    /// Measures `edges` at `positions`.
    pub fn measure(
        &mut self,
        segmentation: &Segmentation,
        edges: &[[u32; 2]],
        positions: &[DVec3],
    ) {
        self.0.resize(edges.len(), EdgeSample::default());
        crate::util::parallel::fill(&mut self.0, |e| {
            let [a, b] = edges[e];
            let d = positions[b as usize] - positions[a as usize];
            let length = d.length();
            EdgeSample {
                d,
                length,
                segment: segmentation.segment_of(length) as u32,
            }
        });
    }
}

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
