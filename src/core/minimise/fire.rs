//! FIRE, the fast inertial relaxation engine (Bitzek, Koskinen, Gähler,
//! Moseler & Gumbsch, PRL 97, 170201, 2006), in the form of Guénolé et al.
//! (Comput. Mater. Sci. 175, 109584, 2020): semi-implicit Euler steps of
//! unit-mass vertices whose velocity is mixed toward the force, with a
//! step that grows while the motion runs downhill and is cut, with the
//! velocity zeroed and half the last step undone, as soon as it runs
//! uphill (F·v ≤ 0).
//!
//! FIRE needs only forces, never an energy or a line search, so it also
//! relaxes force fields that are not exact gradients (forces projected onto
//! a constraint surface, smoothed penalties). The `fire_minimiser` system
//! drives it; this module is the kernel on dense slices.

use crate::params::MinimiserParams;
use glam::DVec3;

/// Steps after a restart before the step may grow (N_delay).
pub const DELAY_STEPS: u32 = 5;
/// Growth factor of the step while running downhill (f_inc).
pub const STEP_GROWTH: f64 = 1.1;
/// Cut of the step on an uphill move (f_dec).
pub const STEP_CUT: f64 = 0.5;
/// Mixing coefficient after a restart (α_start).
pub const ALPHA_START: f64 = 0.1;
/// Decay of the mixing coefficient while running downhill (f_α).
pub const ALPHA_DECAY: f64 = 0.99;
/// Smallest step, as a fraction of the first (Δt_min / Δt_start).
pub const MIN_STEP_FRACTION: f64 = 0.02;

/// FIRE's state: what carries from one step to the next.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Fire {
    /// Velocity by vertex slot (l̄ per unit of fictitious time).
    pub velocity: Vec<DVec3>,
    /// The current step (fictitious time).
    pub dt: f64,
    /// The mixing coefficient α.
    pub alpha: f64,
    /// Consecutive downhill steps.
    pub downhill: u32,
    /// Steps since the last restart.
    pub steps: u64,
    /// The last step's displacement per unit velocity (its Δt times the
    /// scaling to `max_step`), to undo half of it on an uphill move.
    pub last_step: f64,
}

/// What one FIRE step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FireStep {
    /// Largest displacement of a vertex (l̄).
    pub largest_move: f64,
    /// Whether the step was scaled down to `max_step`.
    pub capped: bool,
    /// Whether the motion had turned uphill (velocity zeroed, step cut).
    pub uphill: bool,
}

impl Fire {
    /// A FIRE at rest for `n` vertices.
    pub fn new(n: usize, params: &MinimiserParams) -> Self {
        let mut fire = Self::default();
        fire.restart(n, params);
        fire
    }

    /// Back to rest for `n` vertices: zero velocity, the first step, the
    /// first mixing coefficient (after a topology change, or when a step
    /// folded the mesh).
    pub fn restart(&mut self, n: usize, params: &MinimiserParams) {
        self.velocity.clear();
        self.velocity.resize(n, DVec3::ZERO);
        self.dt = params.dt_start;
        self.alpha = ALPHA_START;
        self.downhill = 0;
        self.steps = 0;
        self.last_step = 0.0;
    }

    /// One step of `positions` (l̄) under `force` (by vertex slot); no
    /// vertex moves by more than `params.max_step`.
    pub fn step(
        &mut self,
        positions: &mut [DVec3],
        force: &[DVec3],
        params: &MinimiserParams,
    ) -> FireStep {
        self.step_along(positions, force, force, params)
    }

    /// One step whose velocity is driven along `direction` (a
    /// preconditioned force, P⁻¹F) while the power F·v that decides
    /// downhill or uphill is measured with the `force` itself, so that
    /// "downhill" means the energy falls whatever the metric. With
    /// `direction` = `force` this is [`Fire::step`].
    pub fn step_along(
        &mut self,
        positions: &mut [DVec3],
        force: &[DVec3],
        direction: &[DVec3],
        params: &MinimiserParams,
    ) -> FireStep {
        debug_assert_eq!(positions.len(), self.velocity.len());
        debug_assert_eq!(force.len(), direction.len());
        let v = &mut self.velocity;
        let power: f64 = force.iter().zip(v.iter()).map(|(f, v)| f.dot(*v)).sum();
        let mut out = FireStep::default();
        if power > 0.0 {
            self.downhill += 1;
            if self.downhill > DELAY_STEPS {
                self.dt = (self.dt * STEP_GROWTH).min(params.dt_max);
                self.alpha *= ALPHA_DECAY;
            }
        } else {
            out.uphill = self.steps > 0;
            self.downhill = 0;
            if self.steps >= DELAY_STEPS as u64 {
                self.dt = (self.dt * STEP_CUT).max(MIN_STEP_FRACTION * params.dt_start);
            }
            self.alpha = ALPHA_START;
            let back = 0.5 * self.last_step;
            for (p, v) in positions.iter_mut().zip(v.iter_mut()) {
                *p -= back * *v;
                *v = DVec3::ZERO;
            }
        }
        let dt = self.dt;
        for (v, f) in v.iter_mut().zip(direction) {
            *v += dt * *f;
        }
        let v_norm = v.iter().map(|v| v.length_squared()).sum::<f64>().sqrt();
        let f_norm = direction
            .iter()
            .map(|f| f.length_squared())
            .sum::<f64>()
            .sqrt();
        if f_norm > 0.0 {
            let (keep, toward) = (1.0 - self.alpha, self.alpha * v_norm / f_norm);
            for (v, f) in v.iter_mut().zip(direction) {
                *v = keep * *v + toward * *f;
            }
        }
        let fastest = v.iter().map(|v| v.length()).fold(0.0, f64::max);
        let mut step = dt;
        if fastest * dt > params.max_step {
            step = params.max_step / fastest;
            out.capped = true;
        }
        for (p, v) in positions.iter_mut().zip(v.iter()) {
            *p += step * *v;
        }
        out.largest_move = fastest * step;
        self.last_step = step;
        self.steps += 1;
        out
    }
}
