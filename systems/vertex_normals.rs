//! The area-weighted vertex normals of the tick ([`crate::fluid`]).
//!
//! Stage: Gather (after `face_geometry`). Reads: [`Membrane`] (faces around
//! each vertex), [`DensePositions`], [`FaceGeometry`] (its normals and areas
//! when a force term had them computed). Writes: [`VertexNormals`].

use crate::engine::force::FaceGeometry;
use crate::engine::resources::{Res, ResMut};
use crate::engine::schedule::System;
use crate::engine::simulation::{DensePositions, SimError};
use crate::fluid::{vertex_normals, vertex_normals_from_faces};
use crate::mesh::membrane::Membrane;
use glam::DVec3;

/// Unit area-weighted vertex normals, n_i ∝ Σ_{f∋i} A_f n̂_f ∝ ∇_i V, by
/// dense slot (inserted by the fluid plugin).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VertexNormals(pub Vec<DVec3>);

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
