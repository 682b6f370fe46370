//! The area-weighted vertex normals of the tick ([`remembrane_core::fluid`]).
//!
//! Stage: Gather (after `face_geometry`). Reads: [`Membrane`] (faces around
//! each vertex), [`DensePositions`], [`FaceGeometry`] (its normals and areas
//! when a force term had them computed). Writes: [`VertexNormals`].

use remembrane_core::engine::force::FaceGeometry;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::shared_resources::VertexNormals;
use remembrane_core::engine::simulation::{DensePositions, SimError};
use remembrane_core::fluid::{vertex_normals, vertex_normals_from_faces};
use remembrane_core::mesh::membrane::Membrane;

/// Its name in the schedule.
pub const VERTEX_NORMALS: &str = "vertex_normals";

/// The vertex-normal system.
pub struct VertexNormalsSystem;

impl System for VertexNormalsSystem {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, FaceGeometry>,
        ResMut<'a, VertexNormals>,
    );

    fn name(&self) -> &str {
        VERTEX_NORMALS
    }

    fn run(
        &mut self,
        (membrane, positions, faces, mut normals): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let t = membrane.cached_topology();
        if faces.0.len() == t.faces.len() {
            vertex_normals_from_faces(&faces.0, t, &mut normals.0);
        } else {
            vertex_normals(&positions.0, t, &mut normals.0);
        }
        Ok(())
    }
}
