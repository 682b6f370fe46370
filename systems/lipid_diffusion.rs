//! Lipid diffusion over mesh edges (SPEC §5, paper Eq. 11).
//!
//! Stage: Diffuse. Runs after every tick whose remeshing was triggered.
//! Reads: [`RemeshTriggered`], [`DensePositions`] (barrier regions), the
//! topology and valences in [`Membrane`]. Writes: [`DenseLipid`] and the
//! world's lipid density (in [`Membrane`]). Each of `sweeps` synchronous sweeps
//! moves k_d ρ_a / v_a from a to b and k_d ρ_b / v_b from b to a over every
//! allowed edge (a, b) (v = valence), so Σρ is conserved; an edge touching a
//! blocked vertex does not diffuse. `Instant` sets ρ = Σρ / N everywhere.

use remembrane_core::diffusion::{blocked, diffuse};
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::shared_resources::RemeshTriggered;
use remembrane_core::engine::simulation::{DenseLipid, DensePositions, SimError};
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::params::{DiffusionParams, DiffusionRate};

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
