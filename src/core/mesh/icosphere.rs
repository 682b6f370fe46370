//! Icosphere generator: a subdivided icosahedron projected onto a sphere.

use super::SurfaceMesh;
use glam::DVec3;
use std::collections::HashMap;

/// Highest subdivision level the generator accepts (163,842 vertices at 7,
/// the largest benchmark size; about 0.5 GB in a run).
pub const MAX_ICOSPHERE_LEVEL: u32 = 7;

/// Vertex count of an icosphere with `level` subdivisions: 10·4^level + 2.
pub fn vertex_count_for_level(level: u32) -> usize {
    10 * 4usize.pow(level) + 2
}

/// Unit-radius icosphere with `level` subdivisions (midpoints projected onto
/// the sphere at every level). Level must be at most [`MAX_ICOSPHERE_LEVEL`].
pub fn icosphere_unit(level: u32) -> SurfaceMesh {
    assert!(
        level <= MAX_ICOSPHERE_LEVEL,
        "icosphere level {level} > {MAX_ICOSPHERE_LEVEL}"
    );
    let t = (1.0 + 5.0_f64.sqrt()) / 2.0;
    let base = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ];
    let mut positions: Vec<DVec3> = base
        .iter()
        .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
        .collect();
    // Counter-clockwise seen from outside.
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, positions: &mut Vec<DVec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *midpoint.entry(key).or_insert_with(|| {
                let p = (positions[a as usize] + positions[b as usize]).normalize();
                positions.push(p);
                (positions.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for &[a, b, c] in &faces {
            let ab = mid(a, b, &mut positions);
            let bc = mid(b, c, &mut positions);
            let ca = mid(c, a, &mut positions);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    SurfaceMesh { positions, faces }
}

/// Icosphere with `level` subdivisions rescaled to mean edge length
/// `mean_edge_length` (l̄). At level 3 and length 1: 642 vertices, radius ≈ 6.634.
pub fn icosphere(level: u32, mean_edge_length: f64) -> SurfaceMesh {
    let mut mesh = icosphere_unit(level);
    mesh.rescale_to_mean_edge_length(mean_edge_length);
    mesh
}

/// The unit icosphere of `level` subdivisions mapped onto the ellipsoid with
/// semi-axes `semi_axes` (l̄): each vertex p goes to (a p.x, b p.y, c p.z), so
/// it lies exactly on the surface. `jitter` > 0 first moves every
/// unit-sphere vertex by a seeded random tangential offset of up to `jitter`
/// times the unit icosphere's mean edge length and projects it back onto
/// the sphere: the vertices stay on the ellipsoid, the triangles get
/// irregular.
pub fn ellipsoid(level: u32, semi_axes: [f64; 3], jitter: f64, seed: u64) -> SurfaceMesh {
    ellipsoid_tilted(level, semi_axes, jitter, 0.0, seed)
}

/// [`ellipsoid`] from the unit icosphere rotated by `tilt` degrees about
/// the x axis before the jitter and the mapping: another triangulation of
/// the same surface (0: exactly [`ellipsoid`]'s). A fluid membrane's
/// equilibrium must not depend on it.
pub fn ellipsoid_tilted(
    level: u32,
    semi_axes: [f64; 3],
    jitter: f64,
    tilt: f64,
    seed: u64,
) -> SurfaceMesh {
    use rand::{RngExt, SeedableRng};
    let mut mesh = icosphere_unit(level);
    if tilt != 0.0 {
        let rotation = glam::DQuat::from_rotation_x(tilt.to_radians());
        for p in &mut mesh.positions {
            *p = rotation * *p;
        }
    }
    if jitter > 0.0 {
        let edge = mesh.mean_edge_length();
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
        for p in &mut mesh.positions {
            // Uniform in the unit ball (rejection), so that the tangential
            // part, the move, is at most 1.
            let offset = loop {
                let o = DVec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                if o.length_squared() <= 1.0 {
                    break o;
                }
            };
            let tangential = offset - offset.dot(*p) * *p;
            *p = (*p + jitter * edge * tangential).normalize();
        }
    }
    let [a, b, c] = semi_axes;
    for p in &mut mesh.positions {
        *p = DVec3::new(a * p.x, b * p.y, c * p.z);
    }
    mesh
}
