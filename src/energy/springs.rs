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
    crate::cell_list::nearest_by_scan(positions, point)
}

/// Spring energy; with `force`, adds the spring forces. Each control point
/// attaches to its nearest vertex and its 1-ring, coupled as `coupling`
/// says; `nearest[k]` is point k's nearest vertex ([`nearest_vertex`], or
/// the same answer from a [`crate::cell_list::CellList`]).
pub fn control_point_springs(
    positions: &[DVec3],
    topology: &crate::topology::Topology,
    points: &[ControlPoint],
    nearest: &[usize],
    coupling: SpringCoupling,
    mut force: Option<&mut [DVec3]>,
) -> f64 {
    let mut energy = 0.0;
    for (cp, &i) in points.iter().zip(nearest) {
        let patch = || std::iter::once(i as u32).chain(topology.neighbours(i).iter().copied());
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
                let n = (topology.valence(i) + 1) as f64;
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
