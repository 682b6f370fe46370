//! Measuring a study's cases against their references: relative errors,
//! the observed convergence order, the cheapest setting per error target,
//! and the outputs `study.csv`, `study.md`, `study.json` and the charts.

use crate::io::plot::{Chart, Legend, Marker, Scale, Series};
use crate::study::peer::{PeerOutput, PeerRun};
use crate::study::reference::{Value, sphere_bending, spheroid_bending};
use crate::study::{Case, Quantity, Reference, Resolution, Study, StudyError};
use serde::Serialize;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;

mod evaluate;
mod measure;
mod write;

pub use evaluate::*;
use measure::*;
pub use write::*;

/// Error targets the report answers "which setting, at what cost" for.
pub const ERROR_TARGETS: [f64; 3] = [1e-2, 1e-3, 1e-4];

/// One measured quantity of a case against its reference.
#[derive(Clone, Debug, Serialize)]
pub struct Measurement {
    /// Name, e.g. `E_b/8πκ`.
    pub quantity: String,
    /// The case's value.
    pub measured: f64,
    /// The reference value.
    pub reference: f64,
    /// The reference's estimated absolute error.
    pub reference_error: f64,
    /// |measured − reference| / |reference|.
    pub error: f64,
}

/// One case's outcome.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    /// `remembrane`, or the peer's name.
    pub engine: String,
    /// Rung label.
    pub rung: String,
    /// Resolution of the rung (its `h`, else N^(-1/2)).
    pub h: f64,
    /// Vertices of the initial mesh.
    pub vertices: usize,
    /// Iterations run.
    pub iterations: u64,
    /// Simulated time (s).
    pub simulated_time: f64,
    /// Wall time of the whole run (s).
    pub wall_s: f64,
    /// The cost the charts use: the stepping systems' time per iteration
    /// for a static problem (building, frames and output excluded), the
    /// whole wall time otherwise (s).
    pub cost_s: f64,
    /// `completed`, `blew_up`, or `failed: reason`.
    pub status: String,
    /// The case is the problem's reference (its finest rung).
    pub is_reference: bool,
    /// The measurements, the primary one first (empty unless completed).
    pub measurements: Vec<Measurement>,
    /// What else the reference compared (the reduced volume it was solved
    /// at, the shape classes), or empty.
    pub note: String,
}

impl CaseResult {
    /// The primary relative error, if the case completed and is not the
    /// reference itself.
    pub fn primary_error(&self) -> Option<f64> {
        (!self.is_reference)
            .then(|| self.measurements.first().map(|m| m.error))
            .flatten()
            .filter(|e| e.is_finite())
    }

    /// The largest relative error over all its measurements (NaN counts as
    /// unmeasured), for "which setting reaches this error" in every quantity.
    pub fn worst_error(&self) -> Option<f64> {
        self.primary_error()?;
        self.measurements
            .iter()
            .map(|m| m.error)
            .try_fold(0.0f64, |w, e| e.is_finite().then_some(w.max(e)))
    }
}

/// The observed order p of error ∝ h^p.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Order {
    /// Least-squares slope of ln(error) against ln(h).
    pub p: f64,
    /// Its standard error (NaN with only two points).
    pub std_error: f64,
    /// Points in the fit.
    pub points: usize,
    /// The fitted line passes through (exp(x̄), exp(ȳ)), the centroid of
    /// the fitted points in ln-ln.
    pub centroid: (f64, f64),
}

/// The cheapest case whose every measurement (E_b, D, thicknesses; r and f)
/// reaches an error target.
#[derive(Clone, Debug, Serialize)]
pub struct Cheapest {
    /// The target relative error.
    pub target: f64,
    /// The rung and its cost (s), if any case reached the target.
    pub rung: Option<(String, f64)>,
}

/// One problem's results.
#[derive(Clone, Debug, Serialize)]
pub struct ProblemResult {
    /// Name.
    pub name: String,
    /// Description.
    pub description: String,
    /// What `cost_s` is.
    pub cost_label: String,
    /// What `h` is.
    pub h_label: String,
    /// The cases, in ladder order.
    pub cases: Vec<CaseResult>,
    /// The peers' cases, by peer and ladder order.
    pub peers: Vec<CaseResult>,
    /// Observed order of the primary error.
    pub order: Option<Order>,
    /// The cheapest rung per error target.
    pub cheapest: Vec<Cheapest>,
    /// Published timings of other codes, as declared.
    pub quoted: Vec<crate::study::Quoted>,
}

/// A study's results.
#[derive(Clone, Debug, Serialize)]
pub struct StudyReport {
    /// The study's name.
    pub name: String,
    /// Per problem.
    pub problems: Vec<ProblemResult>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn systems_time_counts_each_system_once_and_leaves_out_observers() {
        let row = |system: &str, stage: &str, total_s: f64, part_of: Option<&str>| {
            crate::engine::schedule::SystemTiming {
                system: system.into(),
                stage: stage.into(),
                total_s,
                per_tick_us: 0.0,
                share: 0.0,
                part_of: part_of.map(str::to_string),
            }
        };
        let timings = [
            row("gather_state", "Gather", 0.5, None),
            row("force_terms", "Forces", 1.0, None),
            row("bending", "Forces", 0.8, Some("force_terms")),
            row("area", "Forces", 0.7, Some("force_terms")),
            row("frames", "Observe", 5.0, None),
        ];
        assert_eq!(systems_time(&timings), 1.5);
        assert!(systems_time(&[]).is_nan());
    }
}
