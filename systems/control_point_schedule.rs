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

use glam::DVec3;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{Clock, SimError};
use remembrane_core::mesh::components::{ControlPoint, ControlPointIndex};
use remembrane_core::mesh::membrane::Membrane;
use serde::{Deserialize, Serialize};

/// When a scheduled change applies.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum When {
    /// Once, after this many iterations.
    At {
        /// Completed iterations.
        iteration: u64,
    },
    /// Repeatedly: at `start`, `start + interval`, …
    Every {
        /// Iterations between applications (> 0).
        interval: u64,
        /// First application (default 0).
        #[serde(default)]
        start: u64,
        /// No application after this many iterations (default: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        until: Option<u64>,
    },
    /// Repeatedly in simulated time: before the first iteration that starts
    /// at or after `start`, `start + interval`, … (one application per
    /// crossing, however many intervals a step spans).
    EveryTime {
        /// Simulated time between applications (s, > 0).
        interval: f64,
        /// First application (s; default 0).
        #[serde(default)]
        start: f64,
    },
}

impl When {
    /// Whether an iteration-based change applies after `iteration`
    /// completed iterations (always `false` for [`When::EveryTime`]).
    pub fn applies(&self, iteration: u64) -> bool {
        match *self {
            When::At { iteration: n } => iteration == n,
            When::Every {
                interval,
                start,
                until,
            } => {
                iteration >= start
                    && until.is_none_or(|u| iteration <= u)
                    && (iteration - start).is_multiple_of(interval)
            }
            When::EveryTime { .. } => false,
        }
    }

    /// Whether an iteration-based change applies after some iteration
    /// later than `iteration` (always `true` for [`When::EveryTime`], whose
    /// applications are not counted in iterations).
    pub fn applies_after(&self, iteration: u64) -> bool {
        match *self {
            When::At { iteration: n } => n > iteration,
            When::Every {
                interval,
                start,
                until,
            } => {
                let next = if iteration < start {
                    start
                } else {
                    start + ((iteration - start) / interval + 1) * interval
                };
                until.is_none_or(|u| next <= u)
            }
            When::EveryTime { .. } => true,
        }
    }
}

/// What a scheduled change does to each selected point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Change {
    /// Translate by (dx, dy, dz) (l̄).
    MoveBy((f64, f64, f64)),
    /// Move to (x, y, z) (l̄).
    MoveTo((f64, f64, f64)),
    /// Scale the position about `center` by `factor`.
    ScaleAbout {
        /// Centre of the scaling (l̄).
        center: (f64, f64, f64),
        /// Factor (> 0).
        factor: f64,
    },
    /// Set the spring constant (Ē/l̄²).
    SetStiffness(f64),
}

/// One scheduled change.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScheduledChange {
    /// When it applies.
    pub when: When,
    /// Indices of the control points (declaration order) it applies to.
    pub points: Vec<u32>,
    /// The change.
    pub change: Change,
}

fn vec3(v: (f64, f64, f64)) -> DVec3 {
    DVec3::new(v.0, v.1, v.2)
}

impl Change {
    /// Applies the change to one point.
    pub fn apply(&self, point: &mut ControlPoint) {
        match *self {
            Change::MoveBy(d) => point.position += vec3(d),
            Change::MoveTo(p) => point.position = vec3(p),
            Change::ScaleAbout { center, factor } => {
                let c = vec3(center);
                point.position = c + factor * (point.position - c);
            }
            Change::SetStiffness(k) => point.stiffness = k,
        }
    }
}

/// Whether a scheduled change of the control points is still to come after
/// the current iteration (written each tick by [`ControlPointSchedule`];
/// absent without a schedule).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScheduledChangesAhead(pub bool);

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
