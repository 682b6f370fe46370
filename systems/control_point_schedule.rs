//! Scheduled changes of control points (scene data: "at iteration N move or
//! scale these points", "every I iterations move point k by d").
//!
//! Stage: Prepare. Reads: [`Clock`]. Writes: control points (positions and
//! stiffness of the [`ControlPoint`] entities in the [`Membrane`]'s world,
//! by declaration index). A
//! change with `At(iteration: N)` is applied once N iterations are done,
//! i.e. before iteration N + 1 is computed; `Every(interval: I, start: S)`
//! applies at S, S + I, S + 2I, … (up to `until: Some(U)`, if given).
//!
//! The system also writes [`ScheduledChangesAhead`]: whether an
//! iteration-based change is still to come. The minimiser reads it: at rest
//! before a scheduled change it waits for the change instead of stopping
//! the run, which makes `Every` with `MoveBy` a quasi-static protocol.

use remembrane_core::engine::core_resources::ScheduledChangesAhead;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{Clock, SimError};
use remembrane_core::mesh::components::{ControlPoint, ControlPointIndex};
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::params::schedule::{ScheduledChange, When};

/// The control-point schedule system.
pub struct ControlPointSchedule {
    /// The changes, applied in order when due.
    changes: Vec<ScheduledChange>,
    /// Next due time of each change (time-based changes only).
    next_time: Vec<f64>,
}

impl ControlPointSchedule {
    /// A schedule of `changes`.
    pub fn new(changes: Vec<ScheduledChange>) -> Self {
        let next_time = changes
            .iter()
            .map(|c| match c.when {
                When::EveryTime { start, .. } => start,
                _ => f64::INFINITY,
            })
            .collect();
        Self { changes, next_time }
    }
}

impl System for ControlPointSchedule {
    type Data<'a> = (
        Res<'a, Clock>,
        ResMut<'a, Membrane>,
        ResMut<'a, ScheduledChangesAhead>,
    );

    fn name(&self) -> &str {
        "control_point_schedule"
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        // Next due times of the time-based changes (`null` for the others).
        let next: Vec<Option<f64>> = self
            .next_time
            .iter()
            .map(|t| t.is_finite().then_some(*t))
            .collect();
        Some(serde_json::json!({ "next_time": next }))
    }

    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), remembrane_core::engine::error::StateError> {
        let next: Vec<Option<f64>> = state
            .get("next_time")
            .cloned()
            .map(serde_json::from_value)
            .ok_or("no `next_time`")??;
        if next.len() != self.next_time.len() {
            return Err(format!(
                "{} scheduled changes saved, the scene has {}",
                next.len(),
                self.next_time.len()
            )
            .into());
        }
        self.next_time = next
            .into_iter()
            .map(|t| t.unwrap_or(f64::INFINITY))
            .collect();
        Ok(())
    }

    fn run(&mut self, (clock, mut membrane, mut ahead): Self::Data<'_>) -> Result<(), SimError> {
        let (iteration, time) = (clock.iteration, clock.time);
        ahead.0 = self.changes.iter().any(|c| c.when.applies_after(iteration));
        for (change, next) in self.changes.iter().zip(&mut self.next_time) {
            let due = match change.when {
                When::EveryTime { interval, .. } if time >= *next => {
                    while *next <= time {
                        *next += interval;
                    }
                    true
                }
                _ => change.when.applies(iteration),
            };
            if !due {
                continue;
            }
            for (index, point) in membrane
                .world
                .query_mut::<(&ControlPointIndex, &mut ControlPoint)>()
            {
                if change.points.contains(&index.0) {
                    change.change.apply(point);
                }
            }
        }
        Ok(())
    }
}
