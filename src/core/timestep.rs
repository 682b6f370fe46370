//! The adaptive time-step controller (SPEC §3).
//!
//! For an edge (a, b) with d = r_b − r_a of length l in V_in segment s and
//! B = 2μ d·(F_b − F_a) (the rate of change of l² under the forces), the
//! edge may move at most to the midpoint of a neighbouring segment:
//! Δt_e = (l_±² − l²)/B with l_+ the midpoint of segment s+1 when B > 0 and
//! l_− the midpoint of segment s−1 when B < 0; B = 0 gives ∞. The tick's
//! step is Δt = min(dt_max, min_e Δt_e, s_max / max_i |μF_i|).

use crate::energy::vin::{EdgeSample, Segmentation};
use glam::DVec3;

/// What limited the chosen time step.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Limiter {
    /// The cap dt_max.
    #[default]
    Cap,
    /// An edge would otherwise cross more than one V_in segment (edge slot).
    Edge(u32),
    /// A vertex would otherwise move more than s_max (vertex slot).
    Displacement(u32),
    /// The explicit bending step's stability bound (the shortest edge's
    /// slot), in scenes without V_in.
    Bending(u32),
}

/// A chosen time step.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TimeStepChoice {
    /// The step (s).
    pub dt: f64,
    /// What limited it.
    pub limiter: Limiter,
}

/// c of the explicit bending step's stability bound Δt ≤ c·l_min²/(μκ).
///
/// Forward Euler is stable for Δt < 2/(μ λ_max), λ_max the largest
/// eigenvalue of the bending energy's Hessian. The discrete Helfrich energy
/// is scale-free, so λ_max ∝ κ/l² for the shortest edge l. Measured on
/// bending-only icospheres (jitter 0.01 l̄, κ = 1 and 4, levels 3 and 4,
/// mean edge 1 and 2 l̄, μ = 1000; benches/RESULTS.md) the largest step at
/// which the energy falls monotonically is μκΔt/l_min² = 0.050-0.064; this
/// c is 0.8 of the tightest.
pub const BENDING_STABILITY: f64 = 0.04;

/// The explicit bending step's stability bound for bending rigidity
/// `kappa` (Ē) and mobility `mobility`: (Δt in s, slot of the shortest
/// edge). ∞ for κ = 0 or no edges.
pub fn bending_step_limit(
    edges: &[[u32; 2]],
    positions: &[DVec3],
    mobility: f64,
    kappa: f64,
) -> (f64, u32) {
    let (mut shortest, mut slot) = (f64::INFINITY, 0u32);
    for (e, &[a, b]) in edges.iter().enumerate() {
        let l2 = positions[b as usize].distance_squared(positions[a as usize]);
        if l2 < shortest {
            shortest = l2;
            slot = e as u32;
        }
    }
    if kappa <= 0.0 {
        return (f64::INFINITY, slot);
    }
    (BENDING_STABILITY * shortest / (mobility * kappa), slot)
}

/// Time step allowed by one edge of length `l` whose squared length changes
/// at rate `b` = 2μ d·(F_b − F_a) (l̄²/s). Always > 0; ∞ when `b` = 0.
#[inline(always)]
pub fn edge_time_step(segmentation: &Segmentation, l: f64, b: f64) -> f64 {
    edge_time_step_in(segmentation, segmentation.segment_of(l), l, b)
}

/// [`edge_time_step`] for an edge already known to lie in segment `s`.
#[inline(always)]
pub fn edge_time_step_in(segmentation: &Segmentation, s: usize, l: f64, b: f64) -> f64 {
    if b == 0.0 || b.is_nan() {
        return f64::INFINITY;
    }
    let dt = (segmentation.step_target_sq(s, b > 0.0) - l * l) / b;
    // Round-off at a breakpoint can make the numerator vanish: never stall.
    if dt > 0.0 { dt } else { f64::INFINITY }
}

/// Chooses Δt for the current forces. `segmentation = None` (no V_in in the
/// scene) skips the edge criterion. `samples` are the edges measured at
/// `positions` this tick ([`crate::energy::vin::VinEdgeSamples`]); empty:
/// measured here.
#[allow(clippy::too_many_arguments)]
pub fn choose_time_step(
    segmentation: Option<&Segmentation>,
    edges: &[[u32; 2]],
    samples: &[EdgeSample],
    positions: &[DVec3],
    forces: &[DVec3],
    mobility: f64,
    dt_max: f64,
    max_displacement: f64,
) -> TimeStepChoice {
    let mut choice = TimeStepChoice {
        dt: dt_max,
        limiter: Limiter::Cap,
    };
    if let Some(seg) = segmentation {
        let measured = samples.len() == edges.len();
        let edge_dt = |e: usize| {
            let [a, b] = edges[e].map(|i| i as usize);
            let (d, l, s) = if measured {
                let s = samples[e];
                (s.d, s.length, s.segment as usize)
            } else {
                let d = positions[b] - positions[a];
                let l = d.length();
                (d, l, seg.segment_of(l))
            };
            let rate = 2.0 * mobility * d.dot(forces[b] - forces[a]);
            edge_time_step_in(seg, s, l, rate)
        };
        if crate::util::parallel::splits(edges.len()) {
            if let Some((e, dt)) = crate::util::parallel::first_min(edges.len(), choice.dt, edge_dt)
            {
                choice = TimeStepChoice {
                    dt,
                    limiter: Limiter::Edge(e as u32),
                };
            }
        } else {
            for e in 0..edges.len() {
                let dt = edge_dt(e);
                if dt < choice.dt {
                    choice = TimeStepChoice {
                        dt,
                        limiter: Limiter::Edge(e as u32),
                    };
                }
            }
        }
    }
    let (argmax, max_force) = if crate::util::parallel::splits(forces.len()) {
        crate::util::parallel::first_max(forces.len(), 0.0, |i| forces[i].length_squared())
            .unwrap_or((0, 0.0))
    } else {
        let (mut argmax, mut max_force) = (0, 0.0f64);
        for (i, f) in forces.iter().enumerate() {
            let m = f.length_squared();
            if m > max_force {
                max_force = m;
                argmax = i;
            }
        }
        (argmax, max_force)
    };
    let speed = mobility * max_force.sqrt();
    if speed > 0.0 && max_displacement / speed < choice.dt {
        choice = TimeStepChoice {
            dt: max_displacement / speed,
            limiter: Limiter::Displacement(argmax as u32),
        };
    }
    choice
}
