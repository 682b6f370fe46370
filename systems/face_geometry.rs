//! Prepares the force buffers and the shared per-face geometry.
//!
//! Stage: Gather (after `gather_state`). Reads: [`Membrane`] (faces),
//! [`DensePositions`]. Writes: [`FaceGeometry`] (edges, unit normals, areas,
//! cotangents; computed only if a force term uses it), zeroed term buffers
//! in [`ForceBuffers`].

use remembrane_core::engine::force::{FaceGeometry, ForceBuffers};
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{DensePositions, SimError};
use remembrane_core::mesh::membrane::Membrane;

/// The face-geometry system.
pub struct FaceGeometrySystem;

impl System for FaceGeometrySystem {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        ResMut<'a, FaceGeometry>,
        ResMut<'a, ForceBuffers>,
    );

    fn name(&self) -> &str {
        "face_geometry"
    }

    fn run(
        &mut self,
        (membrane, positions, mut geometry, mut buffers): Self::Data<'_>,
    ) -> Result<(), SimError> {
        buffers.begin(positions.0.len());
        if buffers.needs_face_geometry() {
            let faces = &membrane.cached_topology().faces;
            remembrane_core::mesh::geometry::face_geometry(&positions.0, faces, &mut geometry.0);
        } else {
            geometry.0.clear();
        }
        Ok(())
    }
}
