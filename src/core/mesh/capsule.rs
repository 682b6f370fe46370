//! A capsule: a cylinder closed by two hemispherical caps, triangulated in
//! staggered rings of nearly equilateral triangles (the tube of the tether
//! study, started close to its equilibrium shape).

use super::SurfaceMesh;
use super::revolution::{Ring, from_rings};
use std::f64::consts::{FRAC_PI_2, PI};

/// Fewest vertices on a ring (a ring of 5 around each pole gives the poles
/// valence 5).
const MIN_RING: usize = 5;

/// Number of vertices of [`capsule`] with these arguments (without building
/// it), for size limits.
pub fn capsule_vertex_count(radius: f64, length: f64, edge: f64) -> usize {
    // Rings × vertices per ring in floating point, as `rings` will lay
    // them out, before building anything that size: saturates instead of
    // enumerating absurd ring counts (a thin, long capsule has few
    // vertices per ring but very many rings).
    let n = (2.0 * PI * radius / edge)
        .round()
        .max((MIN_RING + 1) as f64);
    let row = 2.0 * radius * (PI / n).sin() * 3f64.sqrt() / 2.0;
    let rows = (length / row).round() + 2.0 * (FRAC_PI_2 * radius / row).round().max(1.0);
    let count = rows * n;
    if count.is_nan() || count >= 1e8 {
        return usize::MAX;
    }
    rings(radius, length, edge)
        .iter()
        .map(|r| r.count)
        .sum::<usize>()
        + 2
}

fn rings(radius: f64, length: f64, edge: f64) -> Vec<Ring> {
    let n = ((2.0 * PI * radius / edge).round() as usize).max(MIN_RING + 1);
    // Rows of equilateral triangles with side = the ring's chord.
    let chord = 2.0 * radius * (PI / n as f64).sin();
    let row = chord * 3f64.sqrt() / 2.0;
    // 0 rows: one ring joins the two caps (a sphere for length 0).
    let cylinder_rows = (length / row).round() as usize;
    let cap_rows = ((FRAC_PI_2 * radius / row).round() as usize).max(1);
    let mut out = Vec::new();
    let stagger = |k: usize, count: usize| (k % 2) as f64 * PI / count as f64;
    let cap_ring = |j: usize, top: bool| {
        // Elevation above the cap's base circle.
        let alpha = FRAC_PI_2 * j as f64 / cap_rows as f64;
        let count = ((n as f64 * alpha.cos()).round() as usize).max(MIN_RING);
        let z = 0.5 * length + radius * alpha.sin();
        (if top { z } else { -z }, radius * alpha.cos(), count)
    };
    // Bottom cap (from the pole's neighbours up to, not including, the base).
    for j in (1..cap_rows).rev() {
        let (z, r, count) = cap_ring(j, false);
        out.push((z, r, count));
    }
    for k in 0..=cylinder_rows {
        let z = if cylinder_rows == 0 {
            0.0
        } else {
            -0.5 * length + length * k as f64 / cylinder_rows as f64
        };
        out.push((z, radius, n));
    }
    for j in 1..cap_rows {
        out.push(cap_ring(j, true));
    }
    // With a single ring between the caps, its two neighbours would share a
    // phase and leave some of its vertices one link on each side: turn the
    // top cap by half a step.
    let top_cap_start = out.len() + 1 - cap_rows;
    out.into_iter()
        .enumerate()
        .map(|(k, (z, radius, count))| Ring {
            z,
            radius,
            count,
            phase: stagger(
                k + usize::from(cylinder_rows == 0 && k >= top_cap_start),
                count,
            ),
        })
        .collect()
}

/// A capsule along the z axis, centred at the origin: a cylinder of
/// `radius` and `length` (l̄; the caps add 2·radius) with hemispherical
/// caps, triangle sides close to `edge` (l̄). Rings of equal size are
/// staggered by half a step; neighbouring rings of different sizes are
/// joined by advancing along whichever ring is behind in angle. Each pole
/// is one vertex.
pub fn capsule(radius: f64, length: f64, edge: f64) -> SurfaceMesh {
    // The poles sit on the caps, at z = ∓(length/2 + radius).
    let pole = 0.5 * length + radius;
    from_rings(-pole, &rings(radius, length, edge), pole)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{ValenceRange, check_mesh};
    use glam::DVec3;

    #[test]
    fn capsules_are_closed_outward_and_regular() {
        for (radius, length) in [
            (1.0, 4.0),
            (2.0, 20.0),
            (3.3, 17.0),
            (6.0, 0.5),
            (2.0, 0.0),
            (2.0, 0.2),
        ] {
            let mesh = capsule(radius, length, 1.0);
            let report = check_mesh(
                &mesh.positions,
                &mesh.faces,
                Some(ValenceRange { min: 5, max: 7 }),
            )
            .unwrap_or_else(|e| panic!("r = {radius}, L = {length}: {e}"));
            assert_eq!(report.components, 1);
            assert_eq!(
                mesh.vertex_count(),
                capsule_vertex_count(radius, length, 1.0)
            );
            let volume =
                crate::mesh::geometry::enclosed_volume(&mesh.positions, &mesh.faces, DVec3::ZERO);
            let exact = PI * radius * radius * (length + 4.0 / 3.0 * radius);
            // Inscribed in the convex capsule: a little smaller (a ring of
            // 6 encloses 83 % of its circle).
            assert!(
                volume > 0.8 * exact && volume < exact,
                "r = {radius}, L = {length}: V = {volume}, exact {exact}"
            );
            let edge = mesh.mean_edge_length();
            assert!((edge - 1.0).abs() < 0.15, "mean edge {edge}");
        }
    }
}
