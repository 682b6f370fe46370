//! The scene's schedule of control-point changes ("at iteration N move or
//! scale these points", "every I iterations move point k by d"), which the
//! `control_point_schedule` system applies.

use crate::mesh::components::ControlPoint;
use glam::DVec3;
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
