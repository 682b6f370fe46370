//! Lipid diffusion over mesh edges (SPEC §5, paper Eq. 11): each of
//! `sweeps` synchronous sweeps moves k_d ρ_a / v_a from a to b and
//! k_d ρ_b / v_b from b to a over every allowed edge (a, b) (v = valence),
//! so Σρ is conserved; an edge touching a blocked vertex does not diffuse.
//! The `lipid_diffusion` system runs it after the ticks that remeshed.

use crate::params::BlockedRegion;
use glam::DVec3;

/// Whether a vertex at `p` lies in a blocked region.
pub fn blocked(regions: &[BlockedRegion], p: DVec3) -> bool {
    regions.iter().any(|r| match *r {
        BlockedRegion::Slab { half_width, gap } => {
            p.x.abs() < half_width && p.y.abs() > gap * p.length()
        }
    })
}

/// `sweeps` synchronous diffusion sweeps at rate `k` over the edges not
/// touching a blocked vertex; `scratch` is reused.
pub fn diffuse(
    density: &mut [f64],
    edges: &[[u32; 2]],
    valence: impl Fn(usize) -> usize,
    allowed: impl Fn(usize) -> bool,
    k: f64,
    sweeps: u32,
    scratch: &mut Vec<f64>,
) {
    let open: Vec<[u32; 2]> = edges
        .iter()
        .copied()
        .filter(|&[a, b]| allowed(a as usize) && allowed(b as usize))
        .collect();
    let share: Vec<f64> = (0..density.len()).map(|v| k / valence(v) as f64).collect();
    for _ in 0..sweeps {
        scratch.clear();
        scratch.extend_from_slice(density);
        for &[a, b] in &open {
            let (a, b) = (a as usize, b as usize);
            let flow = scratch[a] * share[a] - scratch[b] * share[b];
            density[a] -= flow;
            density[b] += flow;
        }
    }
}
