//! Global volume and area penalties and the density-dependent local tension.
//!
//! - volume: E_V = k_V (V − V_t)² / V_t;
//! - area:   E_A = k_A (A − A_t)² / A_t, A = Σ mixed areas = Σ face areas;
//! - local tension: E_a = k_a Σ_i (A_i/ρ_i − a0)² / a0, A_i the mixed area.
//!
//! The global penalties make one face pass that sums the quantity and its
//! unscaled gradient, then scale the gradient by dE/dV (dE/dA).

use crate::mesh::geometry::Corners;
use glam::DVec3;

/// Volume penalty energy; with `force`, adds −∇E_V. `gradient` is scratch.
pub fn volume_penalty(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    k: f64,
    target: f64,
    gradient: &mut Vec<DVec3>,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let origin = positions.first().copied().unwrap_or(DVec3::ZERO);
    let Some(force) = force else {
        let volume = crate::mesh::geometry::enclosed_volume(positions, faces, origin);
        return k * (volume - target).powi(2) / target;
    };
    // 6V = Σ a·(b × c) relative to a fixed origin; ∂(6V)/∂a = b × c, cyclically.
    gradient.clear();
    gradient.resize(positions.len(), DVec3::ZERO);
    let mut six_volume = 0.0;
    for f in faces {
        let (i0, i1, i2) = (f[0] as usize, f[1] as usize, f[2] as usize);
        let a = positions[i0] - origin;
        let b = positions[i1] - origin;
        let c = positions[i2] - origin;
        let bc = b.cross(c);
        six_volume += a.dot(bc);
        gradient[i0] += bc;
        gradient[i1] += c.cross(a);
        gradient[i2] += a.cross(b);
    }
    let volume = six_volume / 6.0;
    let g = 2.0 * k * (volume - target) / target / 6.0;
    for (f, grad) in force.iter_mut().zip(gradient.iter()) {
        *f -= g * *grad;
    }
    k * (volume - target).powi(2) / target
}

/// The volume between the membrane and the plane through `point` with unit
/// `normal`: Σ_f h̄_f (A_f n̂_f · n), h̄_f the mean height of the face's
/// corners above the plane (see [`crate::energy::volume`]).
pub fn volume_above_plane(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    point: DVec3,
    normal: DVec3,
) -> f64 {
    let mut six = 0.0;
    for f in faces {
        let [a, b, c] = f.map(|i| positions[i as usize]);
        let h = (a + b + c - 3.0 * point).dot(normal);
        six += h * (b - a).cross(c - a).dot(normal);
    }
    six / 6.0
}

/// The volume penalty on [`volume_above_plane`]; with `force`, adds −∇E_V.
/// `gradient` is scratch.
pub fn volume_above_plane_penalty(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    (point, normal): (DVec3, DVec3),
    (k, target): (f64, f64),
    gradient: &mut Vec<DVec3>,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let Some(force) = force else {
        let volume = volume_above_plane(positions, faces, point, normal);
        return k * (volume - target).powi(2) / target;
    };
    // 6 V_f = H S2 with H = Σ corner heights and S2 = n·((b − a) × (c − a)):
    // ∂H/∂a = n, ∂S2/∂a = (b − c) × n, cyclically.
    gradient.clear();
    gradient.resize(positions.len(), DVec3::ZERO);
    let mut six_volume = 0.0;
    for f in faces {
        let [a, b, c] = f.map(|i| positions[i as usize]);
        let h = (a + b + c - 3.0 * point).dot(normal);
        let s2 = (b - a).cross(c - a).dot(normal);
        six_volume += h * s2;
        gradient[f[0] as usize] += s2 * normal + h * (b - c).cross(normal);
        gradient[f[1] as usize] += s2 * normal + h * (c - a).cross(normal);
        gradient[f[2] as usize] += s2 * normal + h * (a - b).cross(normal);
    }
    let volume = six_volume / 6.0;
    let g = 2.0 * k * (volume - target) / target / 6.0;
    for (f, grad) in force.iter_mut().zip(gradient.iter()) {
        *f -= g * *grad;
    }
    k * (volume - target).powi(2) / target
}

/// Area penalty energy from the faces' precomputed geometry; with `force`,
/// adds −∇E_A. `gradient` is scratch.
pub fn area_penalty(
    faces: &[[u32; 3]],
    geometry: &[Corners],
    k: f64,
    target: f64,
    gradient: &mut Vec<DVec3>,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let energy_of = |twice_area: f64| {
        let area = 0.5 * twice_area;
        (area, k * (area - target).powi(2) / target)
    };
    let Some(force) = force else {
        return energy_of(geometry.iter().map(|c| c.twice_area).sum()).1;
    };
    // One pass over the faces sums the area and the unscaled gradient
    // ∂(2A_f)/∂p_k = n̂ × e_k (e_k the edge opposite corner k): the face
    // geometry, the largest per-face array, is read once.
    gradient.clear();
    gradient.resize(force.len(), DVec3::ZERO);
    let mut twice_area = 0.0;
    for (f, c) in faces.iter().zip(geometry) {
        twice_area += c.twice_area;
        let (i0, i1, i2) = (f[0] as usize, f[1] as usize, f[2] as usize);
        gradient[i0] += c.n_hat.cross(c.e[0]);
        gradient[i1] += c.n_hat.cross(c.e[1]);
        gradient[i2] += c.n_hat.cross(c.e[2]);
    }
    let (area, energy) = energy_of(twice_area);
    let g = k * (area - target) / target;
    for (f, grad) in force.iter_mut().zip(gradient.iter()) {
        *f -= g * *grad;
    }
    energy
}

/// Reusable buffers for [`local_tension`].
#[derive(Clone, Debug, Default)]
pub struct LocalTensionScratch {
    areas: Vec<f64>,
    g_area: Vec<f64>,
}

/// Local tension energy for per-vertex lipid density `density` and target
/// per-vertex area `a0`, from the faces' precomputed geometry; with `force`,
/// adds −∇E_a.
pub fn local_tension(
    faces: &[[u32; 3]],
    geometry: &[Corners],
    density: &[f64],
    k: f64,
    a0: f64,
    scratch: &mut LocalTensionScratch,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let n = density.len();
    let s = scratch;
    s.areas.clear();
    s.areas.resize(n, 0.0);
    for (f, c) in faces.iter().zip(geometry) {
        let (i0, i1, i2) = (f[0] as usize, f[1] as usize, f[2] as usize);
        let a = c.mixed_areas();
        s.areas[i0] += a[0];
        s.areas[i1] += a[1];
        s.areas[i2] += a[2];
    }
    s.g_area.resize(n, 0.0);
    let mut energy = 0.0;
    for i in 0..n {
        let d = s.areas[i] / density[i] - a0;
        energy += k * d * d / a0;
        s.g_area[i] = 2.0 * k * d / (a0 * density[i]);
    }
    if let Some(force) = force {
        for (f, c) in faces.iter().zip(geometry) {
            let (i0, i1, i2) = (f[0] as usize, f[1] as usize, f[2] as usize);
            let grad = c.backward([DVec3::ZERO; 3], [s.g_area[i0], s.g_area[i1], s.g_area[i2]]);
            force[i0] -= grad[0];
            force[i1] -= grad[1];
            force[i2] -= grad[2];
        }
    }
    energy
}

/// Reusable buffers of [`smooth_over_rings`].
#[derive(Clone, Debug, Default)]
pub struct SmoothingScratch {
    /// The other half of the ping-pong: passes alternate between it and
    /// the force buffer.
    other: Vec<DVec3>,
    /// 1/(1 + valence) per vertex.
    inverse_counts: Vec<f64>,
}

/// Averages `force` over each vertex's closed 1-ring `passes` times:
/// f'(i) = (f(i) + Σ_j f(j)) / (1 + valence_i). Passes alternate between
/// `force` and a scratch buffer, so only an odd pass count copies once.
pub fn smooth_over_rings(
    force: &mut [DVec3],
    topology: &crate::mesh::topology::Topology,
    passes: u32,
    scratch: &mut SmoothingScratch,
) {
    if passes == 0 {
        return;
    }
    let n = force.len();
    let SmoothingScratch {
        other,
        inverse_counts,
    } = scratch;
    crate::util::parallel::fill_vec(inverse_counts, n, |i| {
        1.0 / (1 + topology.valence(i)) as f64
    });
    if other.len() != n {
        // Every element is written by the first pass.
        other.clear();
        other.resize(n, DVec3::ZERO);
    }
    let inverse_counts = &*inverse_counts;
    let pass = |from: &[DVec3], to: &mut [DVec3]| {
        let average = |i: usize| {
            let mut sum = from[i];
            for &j in topology.neighbours(i) {
                sum += from[j as usize];
            }
            sum * inverse_counts[i]
        };
        if crate::util::parallel::splits(n) {
            crate::util::parallel::fill(to, average);
        } else {
            for (i, t) in to.iter_mut().enumerate() {
                *t = average(i);
            }
        }
    };
    for p in 0..passes {
        if p % 2 == 0 {
            pass(force, other);
        } else {
            pass(other, force);
        }
    }
    if passes % 2 == 1 {
        force.copy_from_slice(other);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The smoothing as first written: copy the forces, average into them.
    fn smooth_by_copies(
        force: &mut [DVec3],
        topology: &crate::mesh::topology::Topology,
        passes: u32,
    ) {
        for _ in 0..passes {
            let previous = force.to_vec();
            for (i, f) in force.iter_mut().enumerate() {
                let mut sum = previous[i];
                for &j in topology.neighbours(i) {
                    sum += previous[j as usize];
                }
                *f = sum * DVec3::splat(1.0 / (1 + topology.valence(i)) as f64);
            }
        }
    }

    #[test]
    fn ping_pong_smoothing_has_the_bits_of_copying_for_every_pass_count() {
        let mut membrane =
            crate::mesh::membrane::Membrane::from_mesh(&crate::mesh::icosphere(2, 1.0), false)
                .unwrap();
        let topology = membrane.topology().unwrap().clone();
        let n = topology.vertex_count();
        let forces: Vec<DVec3> = (0..n)
            .map(|i| {
                let x = ((i * 2654435761) % 1000003) as f64 / 1000003.0;
                DVec3::new(x, (1.0 - x).sqrt(), 1.0 / (1.0 + x))
            })
            .collect();
        let mut scratch = SmoothingScratch::default();
        for passes in 0..=5 {
            let (mut expected, mut got) = (forces.clone(), forces.clone());
            smooth_by_copies(&mut expected, &topology, passes);
            smooth_over_rings(&mut got, &topology, passes, &mut scratch);
            assert!(
                got.iter()
                    .zip(&expected)
                    .all(|(a, b)| a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits)),
                "{passes} passes"
            );
        }
    }
}
