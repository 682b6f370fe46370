//! Overdamped Langevin integration (SPEC §3):
//! r ← r + μ F Δt + sqrt(2 μ k_BT Δt) ε, ε ~ N(0, 1) per component.
//!
//! Stage: Integrate. Reads: total force, time step, mobility, k_BT, seed.
//! Writes: positions (dense and world), clock. The noise of tick n comes
//! from its own stream seeded by (seed, n), drawn in vertex-slot order, so a
//! run is reproducible from its seed for any thread count. A step that
//! turns a face over (a vertex crossing the opposite edge: the step was too
//! large for the forces) or turns the membrane inside out (enclosed volume
//! ≤ 0) stops the run with `SimError::MeshFolded` / `InsideOut` and the
//! last good positions kept.

use crate::schedule::{Access, Data, System};
use crate::simulation::{SimError, SimState};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// Stream id of the integrator's noise (distinct from other random streams).
const NOISE_STREAM: u64 = 0x6e6f_6973_6500_0001;

/// Seed of stream `stream` at tick `tick` (SplitMix64 finaliser of the mix).
pub fn stream_seed(seed: u64, stream: u64, tick: u64) -> u64 {
    let mut z = seed ^ stream.rotate_left(17) ^ tick.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The integrator. Keeps the positions before the step to detect faces
/// that turn over within one step.
#[derive(Default)]
pub struct LangevinIntegration {
    previous: Vec<glam::DVec3>,
}

/// Checks a step: the first face (slot) whose orientation reverses between
/// `before` and `after` (a vertex crossed the opposite edge within one
/// step: the step was too large for the forces), and the enclosed volume
/// after the step (l̄³), in one pass over the faces.
pub fn check_step(
    faces: &[[u32; 3]],
    before: &[glam::DVec3],
    after: &[glam::DVec3],
) -> (Option<usize>, f64) {
    let mut turned = None;
    let mut six_volume = 0.0;
    for (k, f) in faces.iter().enumerate() {
        let [a0, b0, c0] = f.map(|v| before[v as usize]);
        let [a, b, c] = f.map(|v| after[v as usize]);
        let n = (b - a).cross(c - a);
        six_volume += a.dot(n);
        if turned.is_none() && (b0 - a0).cross(c0 - a0).dot(n) < 0.0 {
            turned = Some(k);
        }
    }
    (turned, six_volume / 6.0)
}

impl System for LangevinIntegration {
    fn name(&self) -> &str {
        "langevin_integration"
    }

    fn access(&self) -> Access {
        Access::new(
            &[Data::ForceAccumulators, Data::TimeStep, Data::Topology],
            &[Data::Positions, Data::Clock],
        )
    }

    fn run(&mut self, state: &mut SimState) -> Result<(), SimError> {
        let s = state;
        let dt = s.time_step.dt;
        let mu = s.dynamics.mobility;
        let step = mu * dt;
        self.previous.clear();
        self.previous.extend_from_slice(&s.positions);
        for (p, f) in s.positions.iter_mut().zip(&s.evaluation.total) {
            *p += step * *f;
        }
        let kbt = s.dynamics.temperature;
        if kbt > 0.0 {
            let amplitude = (2.0 * mu * kbt * dt).sqrt();
            let tick = s.clock.iteration + 1;
            let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(stream_seed(
                s.seed,
                NOISE_STREAM,
                tick,
            ));
            for p in &mut s.positions {
                let e = glam::DVec3::new(
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                );
                *p += amplitude * e;
            }
        }
        if let Some(v) = s.positions.iter().position(|p| !p.is_finite()) {
            return Err(SimError::BlowUp {
                iteration: s.clock.iteration + 1,
                quantity: "position",
                term: "langevin_integration".into(),
                element: format!("vertex {v}"),
                value: format!("{:?}", s.positions[v]),
            });
        }
        let faces = &s.membrane.cached_topology().faces;
        let (turned, volume) = check_step(faces, &self.previous, &s.positions);
        if let Some(f) = turned {
            let vertices = faces[f];
            // Keep the last good positions (the world is not written yet).
            s.positions.copy_from_slice(&self.previous);
            return Err(SimError::MeshFolded {
                iteration: s.clock.iteration + 1,
                face: f,
                vertices,
                dt,
            });
        }
        // A point reflection (a penalty overshooting through zero size) keeps
        // every face normal: the enclosed volume's sign catches it.
        if volume <= 0.0 {
            s.positions.copy_from_slice(&self.previous);
            return Err(SimError::InsideOut {
                iteration: s.clock.iteration + 1,
                volume,
                dt,
            });
        }
        s.membrane.scatter_positions(&s.positions);
        s.clock.iteration += 1;
        s.clock.time += dt;
        Ok(())
    }
}
