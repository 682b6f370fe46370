//! Lipid diffusion over mesh edges (SPEC §5, paper Eq. 11).
//!
//! Stage: Diffuse. Runs after every tick whose remeshing was triggered.
//! Reads: [`RemeshTriggered`], [`DensePositions`] (barrier regions), the
//! topology and valences in [`Membrane`]. Writes: [`DenseLipid`] and the
//! world's lipid density (in [`Membrane`]). Each of `sweeps` synchronous sweeps
//! moves k_d ρ_a / v_a from a to b and k_d ρ_b / v_b from b to a over every
//! allowed edge (a, b) (v = valence), so Σρ is conserved; an edge touching a
//! blocked vertex does not diffuse. `Instant` sets ρ = Σρ / N everywhere.

use crate::remesh::RemeshTriggered;
use glam::DVec3;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{DenseLipid, DensePositions, SimError};
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::params::{BlockedRegion, DiffusionParams, DiffusionRate};

/// The diffusion system.
pub struct LipidDiffusion {
    /// Rate, sweeps and barrier regions.
    pub params: DiffusionParams,
    next: Vec<f64>,
}

impl LipidDiffusion {
    /// A diffusion system with `params`.
    pub fn new(params: DiffusionParams) -> Self {
        Self {
            params,
            next: Vec::new(),
        }
    }
}

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

impl System for LipidDiffusion {
    type Data<'a> = (
        Res<'a, RemeshTriggered>,
        Res<'a, DensePositions>,
        ResMut<'a, DenseLipid>,
        ResMut<'a, Membrane>,
    );

    fn name(&self) -> &str {
        "lipid_diffusion"
    }

    fn run(
        &mut self,
        (triggered, positions, mut lipid, mut membrane): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let lipid = &mut lipid.0;
        if !triggered.0 || lipid.is_empty() {
            return Ok(());
        }
        let t = membrane.cached_topology();
        match self.params.rate {
            DiffusionRate::Instant => {
                let mean = lipid.iter().sum::<f64>() / lipid.len() as f64;
                lipid.iter_mut().for_each(|r| *r = mean);
            }
            DiffusionRate::Finite(k) => {
                let regions = &self.params.barrier;
                let free: Vec<bool> = positions.0.iter().map(|&p| !blocked(regions, p)).collect();
                diffuse(
                    lipid,
                    &t.edges,
                    |v| t.valence(v),
                    |v| free[v],
                    k,
                    self.params.sweeps,
                    &mut self.next,
                );
            }
        }
        membrane.scatter_lipid(lipid);
        Ok(())
    }
}
