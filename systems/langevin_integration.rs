//! Overdamped Langevin integration (SPEC §3):
//! r ← r + μ F Δt + sqrt(2 μ k_BT Δt) ε, ε ~ N(0, 1) per component.
//!
//! Stage: Integrate. Reads: the total force in [`ForceBuffers`],
//! [`TimeStepChoice`], [`DynamicsParams`] (mobility, k_BT), [`Seed`].
//! Writes: [`DensePositions`], the world's `Position` and `Force`
//! components (in [`Membrane`]), [`Clock`]. The noise of tick n comes
//! from its own stream seeded by (seed, n), drawn in vertex-slot order, so a
//! run is reproducible from its seed for any thread count. A step that
//! turns a face over (a vertex crossing the opposite edge: the step was too
//! large for the forces) or turns the membrane inside out (enclosed volume
//! ≤ 0) stops the run with `SimError::MeshFolded` / `InsideOut` and the
//! last good positions kept.

use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use remembrane_core::engine::force::ForceBuffers;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{Clock, DensePositions, Seed, SimError};
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::mesh::step_check::check_step_with;
use remembrane_core::params::DynamicsParams;
use remembrane_core::timestep::TimeStepChoice;
use remembrane_core::util::rng::stream_seed;

/// Stream id of the integrator's noise (distinct from other random streams).
const NOISE_STREAM: u64 = 0x6e6f_6973_6500_0001;

/// The integrator. Keeps the positions before the step to detect faces
/// that turn over within one step.
#[derive(Default)]
pub struct LangevinIntegration {
    previous: Vec<glam::DVec3>,
    /// Per-face (signed volume term, turned) of the parallel fold check.
    per_face: Vec<(f64, bool)>,
}

impl System for LangevinIntegration {
    type Data<'a> = (
        Res<'a, ForceBuffers>,
        Res<'a, TimeStepChoice>,
        Res<'a, DynamicsParams>,
        Res<'a, Seed>,
        ResMut<'a, DensePositions>,
        ResMut<'a, Membrane>,
        ResMut<'a, Clock>,
    );

    fn name(&self) -> &str {
        "langevin_integration"
    }

    fn run(
        &mut self,
        (buffers, time_step, dynamics, seed, mut positions, mut membrane, mut clock): Self::Data<
            '_,
        >,
    ) -> Result<(), SimError> {
        let dt = time_step.dt;
        let mu = dynamics.mobility;
        let step = mu * dt;
        let total = &buffers.evaluation.total;
        let positions = &mut positions.0;
        // The positions before the step become `previous` (a swap, not a
        // copy) and the drifted positions are written over the old buffer.
        std::mem::swap(&mut self.previous, positions);
        let previous = &self.previous;
        remembrane_core::util::parallel::fill_vec(positions, previous.len(), |v| {
            previous[v] + step * total[v]
        });
        let kbt = dynamics.temperature;
        if kbt > 0.0 {
            let amplitude = (2.0 * mu * kbt * dt).sqrt();
            let tick = clock.iteration + 1;
            let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(stream_seed(
                seed.0,
                NOISE_STREAM,
                tick,
            ));
            for p in positions.iter_mut() {
                let e = glam::DVec3::new(
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                );
                *p += amplitude * e;
            }
        }
        let non_finite = if remembrane_core::util::parallel::splits(positions.len()) {
            remembrane_core::util::parallel::position_first(positions.len(), |v| {
                !positions[v].is_finite()
            })
        } else {
            positions.iter().position(|p| !p.is_finite())
        };
        if let Some(v) = non_finite {
            return Err(SimError::BlowUp {
                iteration: clock.iteration + 1,
                quantity: "position",
                term: "langevin_integration".into(),
                element: format!("vertex {v}"),
                value: format!("{:?}", positions[v]),
            });
        }
        let topology = membrane.cached_topology();
        let faces = &topology.faces;
        let (turned, volume) =
            check_step_with(faces, &self.previous, positions, &mut self.per_face);
        if let Some(f) = turned {
            let vertices = faces[f];
            let corner = vertices.map(|v| v as usize);
            let before = corner.map(|v| self.previous[v]);
            let shortest_edge = (0..3)
                .map(|k| before[k].distance(before[(k + 1) % 3]))
                .fold(f64::INFINITY, f64::min);
            let drift = corner
                .iter()
                .map(|&v| step * total[v].length())
                .fold(0.0, f64::max);
            let noise = (2.0 * mu * kbt * dt).sqrt();
            // Keep the last good positions (the world is not written yet).
            positions.copy_from_slice(&self.previous);
            return Err(SimError::MeshFolded {
                iteration: clock.iteration + 1,
                face: f,
                vertices,
                dt,
                shortest_edge,
                drift,
                noise,
                cause: remembrane_core::engine::error::FoldCause::of(drift, noise),
            });
        }
        // A point reflection (a penalty overshooting through zero size) keeps
        // every face normal: the enclosed volume's sign catches it (on a
        // closed membrane; an open one encloses none).
        if volume <= 0.0 && !topology.is_open() {
            positions.copy_from_slice(&self.previous);
            return Err(SimError::InsideOut {
                iteration: clock.iteration + 1,
                volume,
                dt,
            });
        }
        membrane.scatter_positions_and_forces(positions, total);
        clock.iteration += 1;
        clock.time += dt;
        Ok(())
    }
}
