//! Barrier-crossing detection: the edges outside [l_−, l_+].
//!
//! Stage: BarrierCheck. Reads: [`Membrane`] (edges), [`DensePositions`],
//! the triggers in [`RemeshParams`]. Writes: [`AbnormalEdges`], consumed by
//! remeshing.

use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::shared_resources::AbnormalEdges;
use remembrane_core::engine::simulation::{DensePositions, SimError};
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::params::RemeshParams;

/// The barrier-check system.
pub struct BarrierCheck;

impl System for BarrierCheck {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, RemeshParams>,
        ResMut<'a, AbnormalEdges>,
    );

    fn name(&self) -> &str {
        "barrier_check"
    }

    fn run(
        &mut self,
        (membrane, positions, remesh, mut abnormal): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let (short, long) = (remesh.shorter_than, remesh.longer_than);
        let (short2, long2) = (short * short, long * long);
        let p = &positions.0;
        let edges = &membrane.cached_topology().edges;
        if remembrane_core::util::parallel::splits(edges.len()) {
            remembrane_core::util::parallel::filter_indices(edges.len(), &mut abnormal.0, |e| {
                let [a, b] = edges[e];
                let l2 = p[a as usize].distance_squared(p[b as usize]);
                !(short2..=long2).contains(&l2)
            });
            return Ok(());
        }
        abnormal.0.clear();
        for (e, &[a, b]) in edges.iter().enumerate() {
            let l2 = p[a as usize].distance_squared(p[b as usize]);
            if !(short2..=long2).contains(&l2) {
                abnormal.0.push(e as u32);
            }
        }
        Ok(())
    }
}
