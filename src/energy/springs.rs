//! External Hookean springs from fixed control points (SPEC §2): each control
//! point c pulls its nearest vertex i and every 1-ring neighbour j of i with
//! force k (x_c − x_j); energy ½k|x_c − x_j|² summed over all pulled vertices
//! (the as-run coupling), or ties the centroid of that patch to c
//! ([`SpringCoupling::Centroid`]).

use crate::components::ControlPoint;
use crate::params::SpringCoupling;
use glam::DVec3;

/// Index of the vertex nearest to `point` (ties: lowest index).
pub fn nearest_vertex(positions: &[DVec3], point: DVec3) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (i, p) in positions.iter().enumerate() {
        let d = p.distance_squared(point);
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1
}

/// Spring energy; with `force`, adds the spring forces. Each control point
/// attaches to its nearest vertex (chosen anew on every call) and its 1-ring,
/// coupled as `coupling` says.
pub fn control_point_springs(
    positions: &[DVec3],
    ring_offsets: &[u32],
    ring: &[u32],
    points: &[ControlPoint],
    coupling: SpringCoupling,
    mut force: Option<&mut [DVec3]>,
) -> f64 {
    let mut energy = 0.0;
    for cp in points {
        let i = nearest_vertex(positions, cp.position);
        let (lo, hi) = (ring_offsets[i] as usize, ring_offsets[i + 1] as usize);
        let patch = || std::iter::once(i as u32).chain(ring[lo..hi].iter().copied());
        match coupling {
            SpringCoupling::OneRing => {
                for j in patch() {
                    let d = cp.position - positions[j as usize];
                    energy += 0.5 * cp.stiffness * d.length_squared();
                    if let Some(f) = force.as_deref_mut() {
                        f[j as usize] += cp.stiffness * d;
                    }
                }
            }
            SpringCoupling::Centroid => {
                let n = (hi - lo + 1) as f64;
                let centroid = patch().map(|j| positions[j as usize]).sum::<DVec3>() / n;
                let d = cp.position - centroid;
                energy += 0.5 * cp.stiffness * n * d.length_squared();
                if let Some(f) = force.as_deref_mut() {
                    for j in patch() {
                        f[j as usize] += cp.stiffness * d;
                    }
                }
            }
        }
    }
    energy
}
