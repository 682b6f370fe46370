//! Open patches: a flat disc and a spherical cap, each one boundary loop.
//!
//! Both share the hexagonal-lattice topology of a disc of `K` rings: ring
//! k (k = 1..K) holds 6k vertices, ring 0 the centre alone, and the strip
//! between rings k − 1 and k holds 6(2k − 1) triangles. Interior vertices
//! have valence 6, the rim's 4 (3 at the six sector corners); the mesh has
//! 1 + 3K(K + 1) vertices and 6K² faces. Ring k's vertices sit at equal
//! angles, so the triangles are near equilateral (the sector corners'
//! slightly right-angled).

use super::SurfaceMesh;
use glam::DVec3;
use std::f64::consts::TAU;

/// Vertices of the disc lattice with `rings` rings: 1 + 3K(K + 1).
pub fn patch_vertex_count(rings: u32) -> usize {
    let k = rings as usize;
    1 + 3 * k * (k + 1)
}

/// Vertices of the patch whose radial extent (the disc's radius, the cap's
/// arc from pole to rim) is `length` at `mean_edge_length` (both l̄), as
/// [`disc`] and [`spherical_cap`] choose the rings; saturates instead of
/// overflowing.
pub fn patch_vertex_count_for(length: f64, mean_edge_length: f64) -> usize {
    let k = (EDGE_PER_SPACING * length / mean_edge_length)
        .round()
        .max(1.0);
    if k > 1e6 {
        return usize::MAX;
    }
    patch_vertex_count(k as u32)
}

/// Index of vertex `j` (taken modulo 6k) of ring `k`.
fn index(k: u32, j: u32) -> u32 {
    if k == 0 {
        return 0;
    }
    let first = 1 + 3 * (k - 1) * k;
    first + j % (6 * k)
}

/// The faces of the disc lattice with `rings` rings, counter-clockwise
/// about +z when ring vertices run counter-clockwise in angle.
fn lattice_faces(rings: u32) -> Vec<[u32; 3]> {
    let mut faces = Vec::with_capacity(6 * (rings * rings) as usize);
    for k in 1..=rings {
        for s in 0..6 {
            let outer = |t: u32| index(k, s * k + t);
            let inner = |t: u32| index(k - 1, s * (k - 1) + t);
            for t in 0..k {
                faces.push([outer(t), outer(t + 1), inner(t)]);
                if t + 1 < k {
                    faces.push([inner(t), outer(t + 1), inner(t + 1)]);
                }
            }
        }
    }
    faces
}

/// The lattice's vertices as (ring k, angle φ in radians), in index order.
fn lattice_polar(rings: u32) -> impl Iterator<Item = (u32, f64)> {
    std::iter::once((0, 0.0)).chain(
        (1..=rings).flat_map(|k| (0..6 * k).map(move |j| (k, TAU * j as f64 / (6 * k) as f64))),
    )
}

/// The lattice's mean edge length over its ring spacing (measured: 1.10 at
/// K = 3, 1.12 from K = 10 on; its diagonal edges are longer than the
/// radial ones).
const EDGE_PER_SPACING: f64 = 1.12;

/// Number of rings for a radial extent `length` (l̄) at a mean edge length
/// near `mean_edge_length` (l̄): round(1.12 · length / mean_edge_length),
/// at least 1.
fn ring_count(length: f64, mean_edge_length: f64) -> u32 {
    (EDGE_PER_SPACING * length / mean_edge_length)
        .round()
        .max(1.0) as u32
}

/// A flat disc in the plane z = 0, centred at the origin, of `radius` (l̄),
/// its K rings `radius / K` apart, K chosen so the mean edge length is near
/// `mean_edge_length` (l̄; within about 1/(2K) relative, K being rounded); normal +z (faces counter-clockwise seen from +z). One boundary
/// loop, on the circle of `radius`.
pub fn disc(radius: f64, mean_edge_length: f64) -> SurfaceMesh {
    let rings = ring_count(radius, mean_edge_length);
    let positions = lattice_polar(rings)
        .map(|(k, phi)| {
            let r = radius * k as f64 / rings as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), 0.0)
        })
        .collect();
    SurfaceMesh {
        positions,
        faces: lattice_faces(rings),
    }
}

/// A spherical cap: the part of the sphere of `sphere_radius` (l̄) centred
/// at the origin within `opening_angle` (degrees, in (0, 90]) of the +z
/// pole, its rings at equal polar-angle steps, as many as give a mean edge
/// length near `mean_edge_length` (l̄); normal outward (away from the centre). One
/// boundary loop, on the circle at polar angle `opening_angle`. The
/// azimuthal edges shrink by sin θ / θ towards the rim (to 0.64 at 90°).
pub fn spherical_cap(sphere_radius: f64, opening_angle: f64, mean_edge_length: f64) -> SurfaceMesh {
    let theta_max = opening_angle.to_radians();
    let rings = ring_count(sphere_radius * theta_max, mean_edge_length);
    let positions = lattice_polar(rings)
        .map(|(k, phi)| {
            let theta = theta_max * k as f64 / rings as f64;
            sphere_radius
                * DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                )
        })
        .collect();
    SurfaceMesh {
        positions,
        faces: lattice_faces(rings),
    }
}

/// Largest opening angle of [`spherical_cap`] (degrees).
pub const MAX_CAP_ANGLE: f64 = 90.0;

/// Whether `opening_angle` (degrees) is a valid cap angle: in (0, 90].
pub fn valid_cap_angle(opening_angle: f64) -> bool {
    opening_angle > 0.0 && opening_angle <= MAX_CAP_ANGLE && opening_angle.is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{ValenceRange, check_mesh};
    use std::f64::consts::PI;

    #[test]
    fn disc_is_a_valid_open_patch_with_one_loop() {
        for rings in [1, 2, 5, 8] {
            let m = disc(rings as f64 / EDGE_PER_SPACING, 1.0);
            assert_eq!(m.positions.len(), patch_vertex_count(rings));
            assert_eq!(m.faces.len(), 6 * (rings * rings) as usize);
            let r = check_mesh(&m.positions, &m.faces, Some(ValenceRange::default())).unwrap();
            assert_eq!((r.components, r.boundary_loops), (1, 1));
            // Every face counter-clockwise about +z.
            for f in &m.faces {
                let [a, b, c] = f.map(|v| m.positions[v as usize]);
                assert!((b - a).cross(c - a).z > 0.0);
            }
        }
        // K rounds: 1.12 · radius to the nearest integer.
        for (radius, tol) in [(3.0, 0.1), (6.0, 0.07), (12.5, 0.04)] {
            let mean = disc(radius, 1.0).mean_edge_length();
            assert!((mean - 1.0).abs() < tol, "{radius}: {mean}");
        }
    }

    #[test]
    fn cap_lies_on_its_sphere_and_faces_outward() {
        let m = spherical_cap(6.0, 60.0, 1.0);
        let r = check_mesh(&m.positions, &m.faces, Some(ValenceRange::default())).unwrap();
        assert_eq!(r.boundary_loops, 1);
        for p in &m.positions {
            assert!((p.length() - 6.0).abs() < 1e-12);
            assert!(p.z >= 6.0 * (PI / 3.0).cos() - 1e-12);
        }
        for f in &m.faces {
            let [a, b, c] = f.map(|v| m.positions[v as usize]);
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
        let mean = m.mean_edge_length();
        assert!((mean - 1.0).abs() < 0.05, "{mean}");
        assert!(valid_cap_angle(90.0) && !valid_cap_angle(0.0) && !valid_cap_angle(91.0));
    }
}
