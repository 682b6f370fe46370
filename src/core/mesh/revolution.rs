//! Surfaces of revolution about the z axis, triangulated in rings of nearly
//! equilateral triangles: the capsule's rings, and any meridian profile
//! (e.g. the axisymmetric solver's equilibrium shapes, whose stomatocytes
//! no mapped icosphere resolves).

use super::SurfaceMesh;
use glam::DVec3;
use std::f64::consts::PI;

/// Fewest vertices on a ring of [`revolution`] (a ring of 5 around each
/// pole gives the poles valence 5).
const MIN_RING: usize = 5;

/// One ring of vertices: `count` points at height `z` on a circle of
/// `radius` about the z axis, the first at angle `phase`.
pub(super) struct Ring {
    pub(super) z: f64,
    pub(super) radius: f64,
    pub(super) count: usize,
    pub(super) phase: f64,
}

/// Triangulates the band between ring `lo` (vertices from `lo_start`) and
/// the ring above it, `hi`.
pub(super) fn zip(lo: &Ring, lo_start: u32, hi: &Ring, hi_start: u32, faces: &mut Vec<[u32; 3]>) {
    let step_lo = 2.0 * PI / lo.count as f64;
    let step_hi = 2.0 * PI / hi.count as f64;
    // The upper vertex nearest in angle to the lower ring's first vertex.
    let offset = ((lo.phase - hi.phase) / step_hi).round() as i64;
    let hi_index = |b: usize| (offset + b as i64).rem_euclid(hi.count as i64) as u32 + hi_start;
    let hi_angle = |b: usize| hi.phase + step_hi * (offset + b as i64) as f64;
    let lo_index = |a: usize| (a % lo.count) as u32 + lo_start;
    let lo_angle = |a: usize| lo.phase + step_lo * a as f64;
    let (mut a, mut b) = (0, 0);
    while a < lo.count || b < hi.count {
        let advance_lo = b == hi.count || (a < lo.count && lo_angle(a + 1) <= hi_angle(b + 1));
        if advance_lo {
            faces.push([lo_index(a), lo_index(a + 1), hi_index(b)]);
            a += 1;
        } else {
            faces.push([lo_index(a), hi_index(b + 1), hi_index(b)]);
            b += 1;
        }
    }
}

/// The mesh of poles at `z = bottom` and `z = top` on the axis joined by
/// `rings` (ordered from the bottom pole to the top one along the
/// meridian). Faces are counter-clockwise in the (φ, s) chart, s the
/// meridian's arc length from the bottom pole: outward when the meridian
/// runs with the outside on its right, as it does up a convex wall.
pub(super) fn from_rings(bottom: f64, rings: &[Ring], top: f64) -> SurfaceMesh {
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    let bottom_pole = 0u32;
    positions.push(DVec3::new(0.0, 0.0, bottom));
    let mut starts = Vec::with_capacity(rings.len());
    for ring in rings {
        starts.push(positions.len() as u32);
        for i in 0..ring.count {
            let phi = ring.phase + 2.0 * PI * i as f64 / ring.count as f64;
            positions.push(DVec3::new(
                ring.radius * phi.cos(),
                ring.radius * phi.sin(),
                ring.z,
            ));
        }
    }
    let top_pole = positions.len() as u32;
    positions.push(DVec3::new(0.0, 0.0, top));

    // Counter-clockwise seen from outside: in the (φ, z) chart with z up,
    // (lower i, lower i+1, upper j) and (lower i, upper j+1, upper j).
    let first = &rings[0];
    for i in 0..first.count {
        let a = starts[0] + i as u32;
        let b = starts[0] + ((i + 1) % first.count) as u32;
        faces.push([bottom_pole, b, a]);
    }
    for k in 0..rings.len() - 1 {
        zip(
            &rings[k],
            starts[k],
            &rings[k + 1],
            starts[k + 1],
            &mut faces,
        );
    }
    let last = rings.len() - 1;
    for i in 0..rings[last].count {
        let a = starts[last] + i as u32;
        let b = starts[last] + ((i + 1) % rings[last].count) as u32;
        faces.push([a, b, top_pole]);
    }
    SurfaceMesh { positions, faces }
}

/// Why a meridian profile cannot be turned into a surface.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileError(pub String);

impl std::fmt::Display for ProfileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ProfileError {}

/// Rings of [`revolution`]: rows a triangle height (`edge · √3/2`) apart
/// in arc length along the meridian, each with `2πr / edge` vertices
/// (at least [`MIN_RING`]), staggered by half a step on every other row.
fn profile_rings(profile: &[(f64, f64)], edge: f64) -> Vec<Ring> {
    let mut arc = vec![0.0; profile.len()];
    for i in 1..profile.len() {
        let (r0, z0) = profile[i - 1];
        let (r1, z1) = profile[i];
        arc[i] = arc[i - 1] + (r1 - r0).hypot(z1 - z0);
    }
    let length = arc[profile.len() - 1];
    let rows = ((length / (edge * 3f64.sqrt() / 2.0)).round() as usize).max(2);
    let mut rings = Vec::with_capacity(rows - 1);
    let mut node = 0;
    for k in 1..rows {
        let s = length * k as f64 / rows as f64;
        while arc[node + 1] < s {
            node += 1;
        }
        let t = (s - arc[node]) / (arc[node + 1] - arc[node]);
        let (r0, z0) = profile[node];
        let (r1, z1) = profile[node + 1];
        let radius = r0 + t * (r1 - r0);
        let count = ((2.0 * PI * radius / edge).round() as usize).max(MIN_RING);
        rings.push(Ring {
            z: z0 + t * (z1 - z0),
            radius,
            count,
            phase: (k % 2) as f64 * PI / count as f64,
        });
    }
    rings
}

/// Number of vertices of [`revolution`] with these arguments (without
/// building it), for size limits; `usize::MAX` when absurdly large.
pub fn revolution_vertex_count(profile: &[(f64, f64)], edge: f64) -> usize {
    // Area / (√3/4 edge²) faces, half as many vertices: estimate before
    // laying out rings, which a tiny edge would make without bound.
    let area: f64 = profile
        .windows(2)
        .map(|w| PI * (w[0].0 + w[1].0) * (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
        .sum();
    let estimate = area / (3f64.sqrt() / 2.0 * edge * edge);
    if !estimate.is_finite() || estimate >= 1e8 {
        return usize::MAX;
    }
    profile_rings(profile, edge)
        .iter()
        .map(|r| r.count)
        .sum::<usize>()
        + 2
}

/// The surface swept by the meridian `profile` about the z axis, in rings
/// of nearly equilateral triangles of side close to `edge` (same length
/// unit as the profile).
///
/// `profile` lists `(r, z)` nodes, `r ≥ 0`, from one pole (`r = 0`) to the
/// other, joined by straight segments; it may turn back in `z` and in `r`
/// (an undercut cup). Rows of vertices sit a triangle height apart in arc
/// length, each with `2πr / edge` vertices (at least 5), so triangles are
/// nearly equilateral wherever the radius changes slowly along the
/// meridian; neighbouring rows are joined as the capsule's are. Faces are
/// outward (the orientation is chosen so that the enclosed volume is
/// positive).
///
/// Errors: fewer than 3 nodes, a non-finite coordinate, a negative radius
/// (beyond round-off), ends
/// off the axis, a zero-length meridian, or an `edge` that is not positive
/// and finite.
pub fn revolution(profile: &[(f64, f64)], edge: f64) -> Result<SurfaceMesh, ProfileError> {
    let err = |m: String| Err(ProfileError(m));
    if !(edge.is_finite() && edge > 0.0) {
        return err(format!("the edge length must be positive (got {edge})"));
    }
    if profile.len() < 3 {
        return err(format!(
            "a meridian needs at least 3 nodes (got {})",
            profile.len()
        ));
    }
    if let Some((r, z)) = profile
        .iter()
        .find(|(r, z)| !(r.is_finite() && z.is_finite()))
    {
        return err(format!(
            "every node needs a finite r and z (got ({r}, {z}))"
        ));
    }
    let scale = profile
        .iter()
        .map(|(r, z)| r.abs().max(z.abs()))
        .fold(0.0, f64::max);
    // Round-off on the axis (r = −1e-15) is on the axis.
    let tolerance = 1e-9 * scale;
    if let Some((r, z)) = profile.iter().find(|(r, _)| *r < -tolerance) {
        return err(format!("every node needs r >= 0 (got ({r}, {z}))"));
    }
    let (first, last) = (profile[0], profile[profile.len() - 1]);
    if first.0.abs() > tolerance || last.0.abs() > tolerance {
        return err(format!(
            "the meridian must start and end on the axis (r = 0; got r = {} and {})",
            first.0, last.0
        ));
    }
    let profile: Vec<(f64, f64)> = profile.iter().map(|&(r, z)| (r.max(0.0), z)).collect();
    // Drop repeated nodes so that every segment has a length.
    let mut nodes: Vec<(f64, f64)> = Vec::with_capacity(profile.len());
    for &p in &profile {
        if nodes
            .last()
            .is_none_or(|q: &(f64, f64)| (p.0 - q.0).hypot(p.1 - q.1) > 0.0)
        {
            nodes.push(p);
        }
    }
    if nodes.len() < 2 {
        return err("the meridian has zero length".into());
    }
    let rings = profile_rings(&nodes, edge);
    let mut mesh = from_rings(first.1, &rings, last.1);
    let volume = crate::mesh::geometry::enclosed_volume(&mesh.positions, &mesh.faces, DVec3::ZERO);
    if volume < 0.0 {
        for f in &mut mesh.faces {
            f.swap(1, 2);
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{ValenceRange, check_mesh};

    fn circle(radius: f64, nodes: usize, north_first: bool) -> Vec<(f64, f64)> {
        (0..=nodes)
            .map(|i| {
                let t = PI * i as f64 / nodes as f64;
                let (r, z) = (radius * t.sin(), radius * t.cos());
                (r, if north_first { z } else { -z })
            })
            .collect()
    }

    #[test]
    fn a_half_circle_gives_a_regular_outward_sphere_in_either_direction() {
        for north_first in [true, false] {
            for radius in [2.0, 6.63] {
                let mesh = revolution(&circle(radius, 400, north_first), 1.0).unwrap();
                let report = check_mesh(
                    &mesh.positions,
                    &mesh.faces,
                    Some(ValenceRange { min: 4, max: 8 }),
                )
                .unwrap();
                assert_eq!(report.components, 1);
                assert_eq!(
                    mesh.vertex_count(),
                    revolution_vertex_count(&circle(radius, 400, north_first), 1.0)
                );
                let volume = crate::mesh::geometry::enclosed_volume(
                    &mesh.positions,
                    &mesh.faces,
                    DVec3::ZERO,
                );
                let exact = 4.0 / 3.0 * PI * radius.powi(3);
                assert!(
                    volume > 0.85 * exact && volume < exact,
                    "R = {radius}: V = {volume}, exact {exact}"
                );
                let edge = mesh.mean_edge_length();
                assert!((edge - 1.0).abs() < 0.12, "R = {radius}: mean edge {edge}");
                // On the 400-chord polygon: within its sagitta, R(1 − cos(π/800)).
                for p in &mesh.positions {
                    assert!((p.length() - radius).abs() < 1e-5 * radius);
                }
            }
        }
    }

    #[test]
    fn bad_profiles_are_refused() {
        let ok = circle(2.0, 40, true);
        assert!(revolution(&ok, 0.0).is_err());
        assert!(revolution(&ok, f64::NAN).is_err());
        assert!(revolution(&ok[..2], 1.0).is_err());
        assert!(revolution(&ok[..20], 1.0).is_err());
        let mut nan = ok.clone();
        nan[5].1 = f64::NAN;
        assert!(revolution(&nan, 1.0).is_err());
        let mut negative = ok;
        negative[5].0 = -1.0;
        assert!(revolution(&negative, 1.0).is_err());
    }
}
