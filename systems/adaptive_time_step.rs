//! Chooses the tick's time step (SPEC §3, [`crate::timestep`]).
//!
//! Stage: TimeStep. Reads: positions, total force, topology, V_in
//! segmentation, mobility, dt_max, s_max. Writes: time step. Units: s.

use crate::schedule::{Access, Data, System};
use crate::simulation::{SimError, SimState};
use crate::timestep::{Limiter, choose_time_step};

/// The adaptive time-step system.
pub struct AdaptiveTimeStep;

impl System for AdaptiveTimeStep {
    fn name(&self) -> &str {
        "adaptive_time_step"
    }

    fn access(&self) -> Access {
        Access::new(
            &[Data::Positions, Data::ForceAccumulators, Data::Topology],
            &[Data::TimeStep],
        )
    }

    fn run(&mut self, state: &mut SimState) -> Result<(), SimError> {
        let s = state;
        let d = &s.dynamics;
        let choice = choose_time_step(
            s.segmentation.as_deref(),
            &s.membrane.cached_topology().edges,
            &s.positions,
            &s.evaluation.total,
            d.mobility,
            d.dt_max,
            d.max_displacement,
        );
        if !(choice.dt.is_finite() && choice.dt > 0.0) {
            let element = match choice.limiter {
                Limiter::Edge(e) => format!("edge {e}"),
                Limiter::Displacement(v) => format!("vertex {v}"),
                Limiter::Cap => "the cap".to_string(),
            };
            return Err(SimError::BlowUp {
                iteration: s.clock.iteration + 1,
                quantity: "time step",
                term: "adaptive_time_step".into(),
                element,
                value: format!("{}", choice.dt),
            });
        }
        s.time_step = choice;
        Ok(())
    }
}
