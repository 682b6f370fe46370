//! Global volume and area penalties and the density-dependent local tension.
//!
//! - volume: E_V = k_V (V − V_t)² / V_t;
//! - area:   E_A = k_A (A − A_t)² / A_t, A = Σ mixed areas = Σ face areas;
//! - local tension: E_a = k_a Σ_i (A_i/ρ_i − a0)² / a0, A_i the mixed area.

use crate::geometry::{Corners, face_area_gradient};
use glam::DVec3;

/// Volume penalty energy; with `force`, adds −∇E_V.
pub fn volume_penalty(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    k: f64,
    target: f64,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let origin = positions.first().copied().unwrap_or(DVec3::ZERO);
    let volume = crate::geometry::enclosed_volume(positions, faces, origin);
    let energy = k * (volume - target).powi(2) / target;
    if let Some(force) = force {
        // ∂V/∂p0 = (p1 × p2)/6 relative to the (fixed) origin, cyclically.
        let g = 2.0 * k * (volume - target) / target / 6.0;
        for f in faces {
            let [a, b, c] = f.map(|v| positions[v as usize] - origin);
            force[f[0] as usize] -= g * b.cross(c);
            force[f[1] as usize] -= g * c.cross(a);
            force[f[2] as usize] -= g * a.cross(b);
        }
    }
    energy
}

/// Area penalty energy; with `force`, adds −∇E_A.
pub fn area_penalty(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    k: f64,
    target: f64,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let area = crate::geometry::total_area(positions, faces);
    let energy = k * (area - target).powi(2) / target;
    if let Some(force) = force {
        let g = 2.0 * k * (area - target) / target;
        for f in faces {
            let p = f.map(|v| positions[v as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let grad = face_area_gradient(&p, n / n.length());
            for k in 0..3 {
                force[f[k] as usize] -= g * grad[k];
            }
        }
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
/// per-vertex area `a0`; with `force`, adds −∇E_a.
pub fn local_tension(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    density: &[f64],
    k: f64,
    a0: f64,
    scratch: &mut LocalTensionScratch,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let n = positions.len();
    let s = scratch;
    s.areas.clear();
    s.areas.resize(n, 0.0);
    for f in faces {
        let c = Corners::new(
            positions[f[0] as usize],
            positions[f[1] as usize],
            positions[f[2] as usize],
        );
        let a = c.mixed_areas();
        for k in 0..3 {
            s.areas[f[k] as usize] += a[k];
        }
    }
    s.g_area.clear();
    s.g_area.resize(n, 0.0);
    let mut energy = 0.0;
    for i in 0..n {
        let d = s.areas[i] / density[i] - a0;
        energy += k * d * d / a0;
        s.g_area[i] = 2.0 * k * d / (a0 * density[i]);
    }
    if let Some(force) = force {
        for f in faces {
            let c = Corners::new(
                positions[f[0] as usize],
                positions[f[1] as usize],
                positions[f[2] as usize],
            );
            let grad = c.backward([DVec3::ZERO; 3], f.map(|v| s.g_area[v as usize]));
            for k in 0..3 {
                force[f[k] as usize] -= grad[k];
            }
        }
    }
    energy
}

/// Averages `force` over each vertex's closed 1-ring `passes` times:
/// f'(i) = (f(i) + Σ_j f(j)) / (1 + valence_i). `scratch` is reused.
pub fn smooth_over_rings(
    force: &mut [DVec3],
    ring_offsets: &[u32],
    ring: &[u32],
    passes: u32,
    scratch: &mut Vec<DVec3>,
) {
    for _ in 0..passes {
        scratch.clear();
        scratch.extend_from_slice(force);
        for (i, f) in force.iter_mut().enumerate() {
            let (lo, hi) = (ring_offsets[i] as usize, ring_offsets[i + 1] as usize);
            let mut sum = scratch[i];
            for &j in &ring[lo..hi] {
                sum += scratch[j as usize];
            }
            *f = sum / (1 + hi - lo) as f64;
        }
    }
}
