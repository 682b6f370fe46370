//! Meshes shared by the mesh-check tests.

use glam::DVec3;
use remembrane::mesh::SurfaceMesh;

/// A closed torus (χ = 0): `n` × `m` grid of quads, two triangles each.
pub fn torus(n: u32, m: u32) -> SurfaceMesh {
    let (big, small) = (3.0, 1.0);
    let mut positions = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (u, v) = (
                i as f64 / n as f64 * std::f64::consts::TAU,
                j as f64 / m as f64 * std::f64::consts::TAU,
            );
            positions.push(DVec3::new(
                (big + small * v.cos()) * u.cos(),
                (big + small * v.cos()) * u.sin(),
                small * v.sin(),
            ));
        }
    }
    let id = |i: u32, j: u32| (i % n) * m + (j % m);
    let mut faces = Vec::new();
    for i in 0..n {
        for j in 0..m {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    SurfaceMesh { positions, faces }
}
