//! The mesh: plain triangle meshes (generation, import/export, invariant
//! checks), the hecs world's components and membrane, its dense topology
//! and the edit layer, per-vertex fields, face geometry, quality and a
//! spatial index.
//!
//! [`SurfaceMesh`] is the exchange format between files, generators and the
//! hecs world ([`crate::mesh::membrane::Membrane`]). It is not used in hot loops.

mod capsule;
pub mod cell_list;
pub mod components;
mod docking;
pub mod edit;
pub mod flip;
pub mod geometry;
mod icosphere;
pub mod invariants;
pub mod io;
pub mod membrane;
pub mod patch;
pub mod quality;
mod revolution;
pub mod step_check;
pub mod topology;
pub mod topology_update;
pub mod vertex_field;

pub use capsule::{capsule, capsule_vertex_count};
pub use docking::docked_pair;
pub use icosphere::{
    MAX_ICOSPHERE_LEVEL, ellipsoid, ellipsoid_tilted, icosphere, icosphere_unit,
    vertex_count_for_level,
};
pub use invariants::{MeshError, MeshReport, ValenceRange, check_mesh};
pub use patch::{disc, spherical_cap};
pub use revolution::{ProfileError, revolution, revolution_vertex_count};

use glam::DVec3;
use rand::{RngExt, SeedableRng};

/// A triangle mesh as vertex positions and faces. Faces list vertex indices
/// counter-clockwise seen from outside (right-hand rule, outward normal).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceMesh {
    /// Vertex positions (length l̄ = 1 µm).
    pub positions: Vec<DVec3>,
    /// Faces as vertex-index triples, outward by the right-hand rule.
    pub faces: Vec<[u32; 3]>,
}

impl SurfaceMesh {
    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Unique undirected edges, each as (low, high) vertex index, sorted.
    pub fn edges(&self) -> Vec<[u32; 2]> {
        let mut edges: Vec<[u32; 2]> = self
            .faces
            .iter()
            .flat_map(|f| {
                [0, 1, 2].map(|k| {
                    let (a, b) = (f[k], f[(k + 1) % 3]);
                    [a.min(b), a.max(b)]
                })
            })
            .collect();
        edges.sort_unstable();
        edges.dedup();
        edges
    }

    /// Mean edge length over unique edges.
    pub fn mean_edge_length(&self) -> f64 {
        let edges = self.edges();
        let total: f64 = edges
            .iter()
            .map(|e| self.positions[e[0] as usize].distance(self.positions[e[1] as usize]))
            .sum();
        total / edges.len().max(1) as f64
    }

    /// Each triangle split into four at its edges' midpoints (the
    /// Surface Evolver's `r`): the same polyhedron with edges half as long,
    /// 4F faces and V + E vertices; new vertices follow the old ones, in
    /// the order of the sorted edges, so the result is deterministic.
    /// Orientation is kept. Lipid densities and other per-vertex fields are
    /// the caller's to transfer.
    pub fn subdivided(&self) -> SurfaceMesh {
        let edges = self.edges();
        let n = self.positions.len() as u32;
        let mut positions = self.positions.clone();
        positions.extend(
            edges
                .iter()
                .map(|&[a, b]| 0.5 * (self.positions[a as usize] + self.positions[b as usize])),
        );
        let mid = |a: u32, b: u32| -> u32 {
            let key = [a.min(b), a.max(b)];
            n + edges.binary_search(&key).expect("an edge of the mesh") as u32
        };
        let mut faces = Vec::with_capacity(self.faces.len() * 4);
        for &[a, b, c] in &self.faces {
            let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
            faces.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        SurfaceMesh { positions, faces }
    }

    /// Scales all positions about the origin by `factor`.
    pub fn scale(&mut self, factor: f64) {
        for p in &mut self.positions {
            *p *= factor;
        }
    }

    /// Translates all positions by `offset`.
    pub fn translate(&mut self, offset: DVec3) {
        for p in &mut self.positions {
            *p += offset;
        }
    }

    /// Rescales the mesh about the origin so its mean edge length is `target`.
    pub fn rescale_to_mean_edge_length(&mut self, target: f64) {
        let mean = self.mean_edge_length();
        if mean > 0.0 {
            self.scale(target / mean);
        }
    }

    /// Adds a seeded uniform jitter in [0, amplitude) to every coordinate (the
    /// reference code's `rand(N,3)*1e-4` on the unit sphere, here applied in
    /// the mesh's own length unit).
    pub fn jitter(&mut self, amplitude: f64, seed: u64) {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
        for p in &mut self.positions {
            *p += amplitude * DVec3::new(rng.random(), rng.random(), rng.random());
        }
    }
}

#[cfg(test)]
mod subdivision_tests {
    use super::*;

    #[test]
    fn subdividing_an_icosphere_gives_the_next_level_before_projection() {
        let coarse = icosphere_unit(2);
        let fine = coarse.subdivided();
        let (v, e, f) = (
            coarse.positions.len(),
            coarse.edges().len(),
            coarse.faces.len(),
        );
        assert_eq!(fine.positions.len(), v + e);
        assert_eq!(fine.faces.len(), 4 * f);
        assert_eq!(fine.edges().len(), 2 * e + 3 * f);
        check_mesh(&fine.positions, &fine.faces, None).unwrap();
        // The same polyhedron: the old vertices kept, every new one on an
        // old edge's midpoint, and the edges halved.
        assert_eq!(&fine.positions[..v], &coarse.positions[..]);
        let ratio = fine.mean_edge_length() / coarse.mean_edge_length();
        assert!((ratio - 0.5).abs() < 1e-12, "{ratio}");
        // Projected onto the sphere it is the next icosphere level (as a set
        // of points).
        let key = |p: DVec3| {
            let q = p.normalize();
            [q.x, q.y, q.z].map(|c| (c * 1e9).round() as i64)
        };
        let mut a: Vec<_> = fine.positions.iter().map(|&p| key(p)).collect();
        let mut b: Vec<_> = icosphere_unit(3)
            .positions
            .iter()
            .map(|&p| key(p))
            .collect();
        a.sort();
        b.sort();
        assert_eq!(a, b);
    }
}
