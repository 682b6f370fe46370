//! `remembrane collect DIR`: aggregates the runs of a sweep (paper Fig 5E/F).
//!
//! For every run, the first `frames` rows of `series.csv` give the curve
//! y(x) (by default the right tether's normalised radius against the
//! left's); a 4th-order least-squares polynomial is fitted and evaluated at
//! the last x: the coupling metric (Fig 5E circles). Per condition and grid
//! point, the metric's mean and standard deviation over repeats (Fig 5F).
//!
//! Writes `collect_runs.csv` (one row per run), `collect.csv` (one row per
//! condition × grid point), `fig5f.png` (metric against the first grid
//! axis, one line per condition, ± 1 sd) and `fig5e_<point>.png` (fitted
//! curves per condition, one PNG per grid point).

use crate::io::plot::{Series, line_chart};
use crate::workflow::sweep::{RunSpec, SweepIndex};
use std::path::{Path, PathBuf};

/// Options of [`collect`].
#[derive(Clone, Debug)]
pub struct CollectOptions {
    /// series.csv column on the x axis.
    pub x: String,
    /// series.csv column on the y axis.
    pub y: String,
    /// Rows (frames) used from the start of each series (the reference uses
    /// the initial frame and 30 pull intervals).
    pub frames: usize,
    /// Polynomial degree of the fit (paper: 4).
    pub degree: usize,
}

impl Default for CollectOptions {
    fn default() -> Self {
        Self {
            x: "radius_left_norm".into(),
            y: "radius_right_norm".into(),
            frames: 31,
            degree: 4,
        }
    }
}

/// One run's result.
#[derive(Clone, Debug, PartialEq)]
pub struct RunResult {
    /// The run.
    pub spec: RunSpec,
    /// `completed` or `blew_up` (from summary.json).
    pub status: String,
    /// Points (x, y) used.
    pub points: Vec<(f64, f64)>,
    /// Fit coefficients, lowest order first (None: too few points).
    pub fit: Option<Vec<f64>>,
    /// Fitted y at the last x (the metric).
    pub metric: Option<f64>,
}

/// One condition × grid point.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupRow {
    /// Condition.
    pub condition: String,
    /// Grid point labels.
    pub point: Vec<(String, String)>,
    /// Numeric value of the first axis, if any.
    pub x: Option<f64>,
    /// Runs with a metric.
    pub n: usize,
    /// Mean metric.
    pub mean: f64,
    /// Sample standard deviation (0 for one run).
    pub sd: f64,
}

/// What [`collect`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct CollectReport {
    /// Runs in the sweep.
    pub expected: usize,
    /// Runs without results (directory or summary missing).
    pub missing: Vec<PathBuf>,
    /// Per-run results.
    pub runs: Vec<RunResult>,
    /// Per-group statistics.
    pub groups: Vec<GroupRow>,
}

/// Why collecting failed.
#[derive(Debug, thiserror::Error)]
#[error("{}: {reason}", path.display())]
pub struct CollectError {
    /// The file at fault.
    pub path: PathBuf,
    /// What is wrong.
    pub reason: String,
}

/// Least-squares polynomial of `degree` through `points` (lowest order
/// first); `None` with fewer than degree + 1 points.
pub fn polyfit(points: &[(f64, f64)], degree: usize) -> Option<Vec<f64>> {
    if points.len() <= degree {
        return None;
    }
    let a = nalgebra::DMatrix::from_fn(points.len(), degree + 1, |i, j| points[i].0.powi(j as i32));
    let b = nalgebra::DVector::from_iterator(points.len(), points.iter().map(|p| p.1));
    let c = a.svd(true, true).solve(&b, 1e-12).ok()?;
    let c: Vec<f64> = c.iter().copied().collect();
    c.iter().all(|v| v.is_finite()).then_some(c)
}

/// Evaluates a polynomial (lowest order first).
pub fn polyval(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &k| acc * x + k)
}

/// The (x, y) points of the first `options.frames` rows of a run's
/// `series.csv` (typed reader: a missing column or an unreadable value is
/// an error naming the file, the column and the line), rows where either is
/// not finite left out.
fn read_points(run_dir: &Path, options: &CollectOptions) -> Result<Vec<(f64, f64)>, CollectError> {
    let series = crate::io::run_dir::Series::read(run_dir).map_err(CollectError::from)?;
    let (cx, cy) = (
        series.index(&options.x).map_err(CollectError::from)?,
        series.index(&options.y).map_err(CollectError::from)?,
    );
    Ok(series
        .rows
        .iter()
        .take(options.frames)
        .map(|r| (r[cx], r[cy]))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect())
}

impl From<crate::io::run_dir::RunDirError> for CollectError {
    fn from(e: crate::io::run_dir::RunDirError) -> Self {
        let reason = match &e.field {
            Some(f) => format!("field `{f}`: {}", e.reason),
            None => e.reason.clone(),
        };
        CollectError {
            path: e.path,
            reason,
        }
    }
}

/// Aggregates the sweep output in `dir` and writes the tables and charts.
pub fn collect(dir: &Path, options: &CollectOptions) -> Result<CollectReport, CollectError> {
    let index_path = dir.join("sweep.json");
    let index: SweepIndex = std::fs::read_to_string(&index_path)
        .map_err(|e| format!("not a sweep output directory (cannot read sweep.json: {e})"))
        .and_then(|t| serde_json::from_str(&t).map_err(|e| format!("malformed: {e}")))
        .map_err(|reason| CollectError {
            path: index_path.clone(),
            reason,
        })?;
    let mut report = CollectReport {
        expected: index.runs.len(),
        missing: Vec::new(),
        runs: Vec::new(),
        groups: Vec::new(),
    };
    for spec in &index.runs {
        let run_dir = dir.join(&spec.dir);
        if !run_dir.join("summary.json").is_file() {
            report.missing.push(spec.dir.clone());
            continue;
        }
        let summary = crate::io::summary::RunSummary::read(&run_dir)?;
        let status = match summary.status {
            crate::io::summary::RunStatus::Completed => "completed",
            crate::io::summary::RunStatus::BlewUp => "blew_up",
        }
        .to_string();
        let points = read_points(&run_dir, options)?;
        let fit = polyfit(&points, options.degree);
        let metric = match (&fit, points.last()) {
            (Some(c), Some(&(x, _))) => Some(polyval(c, x)),
            _ => None,
        };
        report.runs.push(RunResult {
            spec: spec.clone(),
            status,
            points,
            fit,
            metric,
        });
    }
    // Groups in expansion order.
    let mut keys: Vec<(String, Vec<(String, String)>)> = Vec::new();
    for r in &report.runs {
        let key = (r.spec.condition.clone(), r.spec.point.clone());
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    for (condition, point) in keys {
        let members: Vec<&RunResult> = report
            .runs
            .iter()
            .filter(|r| r.spec.condition == condition && r.spec.point == point)
            .collect();
        let values: Vec<f64> = members.iter().filter_map(|r| r.metric).collect();
        let n = values.len();
        let mean = values.iter().sum::<f64>() / n.max(1) as f64;
        let sd = if n > 1 {
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        report.groups.push(GroupRow {
            x: members[0].spec.point_values.first().copied().flatten(),
            condition,
            point,
            n,
            mean: if n > 0 { mean } else { f64::NAN },
            sd,
        });
    }
    write_outputs(dir, &index, &report, options)?;
    Ok(report)
}

fn write_outputs(
    dir: &Path,
    index: &SweepIndex,
    report: &CollectReport,
    options: &CollectOptions,
) -> Result<(), CollectError> {
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        crate::atomic_write(&path, bytes).map_err(|e| CollectError {
            path,
            reason: format!("cannot write: {e}"),
        })
    };
    write(
        "collect_runs.csv",
        runs_csv(index, report, options).as_bytes(),
    )?;
    write("collect.csv", groups_csv(index, report, options).as_bytes())?;

    // Fig 5F: metric against the first axis, one series per condition.
    let mut conditions: Vec<String> = Vec::new();
    for g in &report.groups {
        if !conditions.contains(&g.condition) {
            conditions.push(g.condition.clone());
        }
    }
    let first_axis = index.axes.first().cloned().unwrap_or_else(|| "run".into());
    let scan: Vec<Series> = conditions
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let rows: Vec<&crate::workflow::collect::GroupRow> =
                report.groups.iter().filter(|g| &g.condition == c).collect();
            Series {
                name: c.clone(),
                points: rows
                    .iter()
                    .enumerate()
                    .map(|(i, g)| (g.x.unwrap_or(i as f64), g.mean))
                    .collect(),
                errors: rows.iter().map(|g| g.sd).collect(),
                lines: true,
                markers: true,
                color: k,
                ..Default::default()
            }
        })
        .collect();
    write(
        "fig5f.png",
        &line_chart(
            &format!("{} at the end (fit)", options.y),
            &first_axis,
            &options.y,
            &scan,
        ),
    )?;

    // Fig 5E: per grid point, the fitted curves of every run.
    let mut points: Vec<Vec<(String, String)>> = Vec::new();
    for g in &report.groups {
        if !points.contains(&g.point) {
            points.push(g.point.clone());
        }
    }
    for point in points {
        let series = fitted_curves(report, &conditions, &point);
        let label: Vec<String> = point.iter().map(|(a, v)| format!("{a}={v}")).collect();
        let suffix = if label.is_empty() {
            "all".to_string()
        } else {
            label.join("_")
        };
        write(
            &format!("fig5e_{suffix}.png"),
            &line_chart(
                &format!("{} vs {} ({})", options.y, options.x, label.join(" ")),
                &options.x,
                &options.y,
                &series,
            ),
        )?;
    }
    Ok(())
}

/// `collect_runs.csv`: one row per run, its last point and fitted metric.
fn runs_csv(index: &SweepIndex, report: &CollectReport, options: &CollectOptions) -> String {
    let axes = index.axes.join(",");
    let sep = if axes.is_empty() { "" } else { "," };
    let mut runs_csv = format!(
        "condition{sep}{axes},repeat,seed,status,frames,{x}_last,{y}_last,{y}_fit_last,dir\n",
        x = options.x,
        y = options.y
    );
    for r in &report.runs {
        let labels: Vec<&str> = r.spec.point.iter().map(|(_, v)| v.as_str()).collect();
        let last = r.points.last().copied().unwrap_or((f64::NAN, f64::NAN));
        runs_csv += &format!(
            "{}{sep}{},{},{},{},{},{:.6},{:.6},{:.6},{}\n",
            r.spec.condition,
            labels.join(","),
            r.spec.repeat,
            r.spec.seed,
            r.status,
            r.points.len(),
            last.0,
            last.1,
            r.metric.unwrap_or(f64::NAN),
            r.spec.dir.display()
        );
    }
    runs_csv
}

/// `collect.csv`: one row per condition and grid point, the mean and
/// spread of the fitted metric.
fn groups_csv(index: &SweepIndex, report: &CollectReport, options: &CollectOptions) -> String {
    let axes = index.axes.join(",");
    let sep = if axes.is_empty() { "" } else { "," };
    let mut groups_csv = format!(
        "condition{sep}{axes},runs,{y}_fit_last_mean,{y}_fit_last_sd\n",
        y = options.y
    );
    for g in &report.groups {
        let labels: Vec<&str> = g.point.iter().map(|(_, v)| v.as_str()).collect();
        groups_csv += &format!(
            "{}{sep}{},{},{:.6},{:.6}\n",
            g.condition,
            labels.join(","),
            g.n,
            g.mean,
            g.sd
        );
    }
    groups_csv
}

/// Fig 5E's series at one grid point: each run's fitted curve over its
/// range (named once per condition) and its fitted end value.
fn fitted_curves(
    report: &CollectReport,
    conditions: &[String],
    point: &[(String, String)],
) -> Vec<Series> {
    let mut series = Vec::new();
    for (k, c) in conditions.iter().enumerate() {
        let mut named = false;
        for r in report
            .runs
            .iter()
            .filter(|r| &r.spec.condition == c && r.spec.point == point)
        {
            let Some(fit) = &r.fit else { continue };
            let (lo, hi) = r
                .points
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                    (a.min(p.0), b.max(p.0))
                });
            let curve = (0..=40)
                .map(|i| {
                    let x = hi + (lo - hi) * i as f64 / 40.0;
                    (x, polyval(fit, x))
                })
                .collect();
            series.push(Series {
                name: if named { String::new() } else { c.clone() },
                points: curve,
                lines: true,
                color: k,
                ..Default::default()
            });
            series.push(Series {
                points: r
                    .metric
                    .map(|m| vec![(r.points.last().map_or(f64::NAN, |p| p.0), m)])
                    .unwrap_or_default(),
                markers: true,
                color: k,
                ..Default::default()
            });
            named = true;
        }
    }
    series
}
