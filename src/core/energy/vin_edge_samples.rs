//! Every edge measured once per tick for V_in: its vector, length and
//! segment ([`VinEdgeSamples`]), read by the V_in force and the time-step
//! rule instead of each gathering the end positions, taking the square root
//! and looking up the segment again. V_in's plugin measures them in the
//! Gather stage (`super::vin::VinEdgeSampling`).

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
    /// Measures `edges` at `positions`; `segment_of` gives a length's
    /// V_in segment (`Segmentation::segment_of`).
    pub fn measure(
        &mut self,
        edges: &[[u32; 2]],
        positions: &[DVec3],
        segment_of: impl Fn(f64) -> usize + Sync,
    ) {
        self.0.resize(edges.len(), EdgeSample::default());
        crate::util::parallel::fill(&mut self.0, |e| {
            let [a, b] = edges[e];
            let d = positions[b as usize] - positions[a as usize];
            let length = d.length();
            EdgeSample {
                d,
                length,
                segment: segment_of(length) as u32,
            }
        });
    }
}
