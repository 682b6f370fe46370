//! Measuring a study's cases against their references: relative errors,
//! the observed convergence order, the cheapest setting per error target,
//! and the outputs `study.csv`, `study.md`, `study.json` and the charts.

use crate::io::plot::{Chart, Legend, Marker, Scale, Series};
use crate::study::peer::{PeerOutput, PeerRun};
use crate::study::reference::{Value, sphere_bending, spheroid_bending};
use crate::study::{Case, Quantity, Reference, Resolution, Study, StudyError, bending_kappa};
use serde::Serialize;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;

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

/// A run directory's outputs needed here.
struct RunData {
    summary: crate::workflow::run::RunSummary,
    /// Every row of series.csv by column name, the first included.
    rows: Vec<HashMap<String, f64>>,
    /// The vertex count of the first row.
    vertices: f64,
    /// The bending energy of the first row (NaN without a bending term).
    initial_bending: f64,
}

fn read_run(dir: &Path) -> Result<RunData, String> {
    let summary = crate::workflow::run::RunSummary::read(dir).map_err(|e| e.to_string())?;
    let series = crate::io::run_dir::Series::read(dir).map_err(|e| e.to_string())?;
    let vertices = series.first("vertices").map_err(|e| e.to_string())?;
    let initial_bending = series.first("energy_bending").unwrap_or(f64::NAN);
    let rows = series
        .rows
        .iter()
        .map(|row| {
            series
                .columns
                .iter()
                .cloned()
                .zip(row.iter().copied())
                .collect()
        })
        .collect();
    Ok(RunData {
        summary,
        rows,
        vertices,
        initial_bending,
    })
}

/// The final bending energy in a summary (NaN without a bending term).
fn final_bending(summary: &crate::workflow::run::RunSummary) -> f64 {
    summary
        .last
        .energies
        .iter()
        .find(|t| t.term == "bending")
        .map_or(f64::NAN, |t| t.energy)
}

fn quantity(summary: &crate::workflow::run::RunSummary, q: Quantity) -> f64 {
    match q {
        Quantity::ReducedVolume => summary.last.reduced_volume,
        Quantity::BendingEnergy => final_bending(summary),
        Quantity::TotalEnergy => summary.last.total_energy,
        Quantity::Area => summary.last.area,
        Quantity::Volume => summary.last.volume,
    }
}

fn measure(quantity: &str, measured: f64, reference: Value) -> Measurement {
    Measurement {
        quantity: quantity.into(),
        measured,
        reference: reference.value,
        reference_error: reference.error,
        error: ((measured - reference.value) / reference.value).abs(),
    }
}

/// The axisymmetric reference's measurements of a final mesh: the
/// reference is solved at the mesh's reduced volume `v`; R0 = √(A/4π).
fn axisymmetric_measurements(
    mesh_path: &Path,
    energy_bending: f64,
    area: f64,
    v: f64,
    kappa: f64,
) -> Result<(Vec<Measurement>, String), String> {
    let r0 = (area / (4.0 * PI)).sqrt();
    let exact = crate::study::axisymmetric::converged(v)
        .map_err(|e| format!("reference at v = {v}: {e}"))?;
    let mesh = crate::mesh::io::read_mesh(mesh_path).map_err(|e| e.to_string())?;
    let t = crate::analysis::shape::axial_thickness(&mesh.positions, &mesh.faces);
    let class = crate::analysis::shape::shape_metrics(&mesh.positions, &mesh.faces).class;
    let value = |x: crate::study::axisymmetric::Extrapolated| Value {
        value: x.value,
        error: x.error,
    };
    let note = format!(
        "solved at the case's v = {v:.4}; shape: mesh {}, reference {}",
        serde_json::to_value(class)
            .ok()
            .and_then(|c| c.as_str().map(str::to_string))
            .unwrap_or_default(),
        if exact.biconcave {
            "discocyte"
        } else {
            "convex"
        }
    );
    let measurements = vec![
        measure(
            "E_b/8πκ",
            energy_bending / (8.0 * PI * kappa),
            value(exact.energy_over_8pi_kappa),
        ),
        measure("D/R0", t.diameter / r0, value(exact.diameter)),
        measure("t_max/R0", t.max / r0, value(exact.max_thickness)),
        measure("t_centre/R0", t.centre / r0, value(exact.centre_thickness)),
    ];
    Ok((measurements, note))
}

/// Equilibrium tolerance on the bending energy: within this fraction of its
/// final value (the RBC's E_b moves by ±0.4 % between frames at rest).
const EQUILIBRIUM_ENERGY_TOLERANCE: f64 = 0.01;
/// Equilibrium tolerance on the reduced volume (absolute).
const EQUILIBRIUM_V_TOLERANCE: f64 = 1e-3;

/// When a run reached equilibrium: the first frame from which on every frame
/// has E_b within [`EQUILIBRIUM_ENERGY_TOLERANCE`] and v within
/// [`EQUILIBRIUM_V_TOLERANCE`] of the final frame's, as a sentence with its
/// simulated time and iteration.
fn equilibration(rows: &[HashMap<String, f64>]) -> String {
    let get = |r: &HashMap<String, f64>, k: &str| r.get(k).copied().unwrap_or(f64::NAN);
    let Some(last) = rows.last() else {
        return String::new();
    };
    let (e_end, v_end) = (get(last, "energy_bending"), get(last, "reduced_volume"));
    let settled = |r: &HashMap<String, f64>| {
        (get(r, "energy_bending") - e_end).abs() <= EQUILIBRIUM_ENERGY_TOLERANCE * e_end.abs()
            && (get(r, "reduced_volume") - v_end).abs() <= EQUILIBRIUM_V_TOLERANCE
    };
    let first = rows.len() - rows.iter().rev().take_while(|r| settled(r)).count();
    let tolerance = format!(
        "E_b within {} % and v within {EQUILIBRIUM_V_TOLERANCE:e} of their final values",
        EQUILIBRIUM_ENERGY_TOLERANCE * 100.0
    );
    if first + 1 >= rows.len() {
        return format!("not shown at equilibrium: only the last frame has {tolerance}");
    }
    format!(
        "at equilibrium ({tolerance} from then on) from t = {:.4} s, iteration {} (of {} frames, {})",
        get(&rows[first], "time"),
        get(&rows[first], "iteration"),
        rows.len(),
        if first == 0 {
            "already at the first"
        } else {
            "resolution one frame"
        }
    )
}

/// The exact bending energy of a static problem's initial shape (None for
/// other references, or a spheroid problem whose membrane is not one).
fn static_reference(reference: Reference, case: &Case) -> Option<Value> {
    let kappa = bending_kappa(&case.scene).unwrap_or(f64::NAN);
    match (reference, &case.scene.membrane) {
        (Reference::SphereBending, _) => Some(sphere_bending(kappa)),
        (
            Reference::SpheroidBending,
            crate::scene::MembraneSource::Ellipsoid {
                semi_axes: (a, _, c),
                ..
            },
        ) => Some(spheroid_bending(*a, *c, kappa)),
        _ => None,
    }
}

/// A peer's measurements against the problem's reference.
fn peer_measurements(
    reference: Reference,
    case: &Case,
    output: &PeerOutput,
) -> Result<(Vec<Measurement>, String), String> {
    let kappa = bending_kappa(&case.scene).unwrap_or(f64::NAN);
    match reference {
        Reference::SphereBending | Reference::SpheroidBending => {
            let exact = static_reference(reference, case).ok_or("not an ellipsoid")?;
            Ok((
                vec![measure("E_b", output.energy_bending, exact)],
                String::new(),
            ))
        }
        Reference::Axisymmetric => {
            let mesh = output.mesh.as_ref().ok_or("the peer wrote no final mesh")?;
            axisymmetric_measurements(
                mesh,
                output.energy_bending,
                output.area.unwrap_or(f64::NAN),
                output.reduced_volume.unwrap_or(f64::NAN),
                kappa,
            )
        }
        Reference::FinestRung(_) => Err("a time-step problem has no peer version".into()),
        Reference::Tether => Err("the tether problem has no peer version".into()),
    }
}

/// The tether's radius and force over the second half of the frames
/// (medians) against Derényi-Jülicher-Prost, r0 = √(κ/2σ) and
/// f0 = 2π√(2σκ).
fn tether_measurements(scene: &crate::scene::Scene, d: &RunData) -> (Vec<Measurement>, String) {
    let kappa = bending_kappa(scene).unwrap_or(f64::NAN);
    let sigma = scene
        .energy
        .iter()
        .find_map(|t| match t {
            crate::scene::EnergyTerm::Tension(p) => Some(p.sigma),
            _ => None,
        })
        .unwrap_or(f64::NAN);
    let r0 = (kappa / (2.0 * sigma)).sqrt();
    let f0 = 2.0 * std::f64::consts::PI * (2.0 * sigma * kappa).sqrt();
    let late = &d.rows[d.rows.len() / 2..];
    let median = |mut v: Vec<f64>| {
        v.retain(|x| x.is_finite());
        v.sort_by(f64::total_cmp);
        match v.len() {
            0 => f64::NAN,
            n if n % 2 == 1 => v[n / 2],
            n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
        }
    };
    let radius_column = scene
        .tube_radius
        .first()
        .map(|p| format!("radius_{}", p.name))
        .unwrap_or_default();
    let force_columns: Vec<String> = scene
        .control_points
        .iter()
        .filter_map(|c| c.name.as_ref().map(|n| format!("force_{n}")))
        .collect();
    let value = |row: &HashMap<String, f64>, c: &String| row.get(c).copied().unwrap_or(f64::NAN);
    let radius = median(late.iter().map(|r| value(r, &radius_column)).collect());
    let force = median(
        late.iter()
            .map(|r| {
                force_columns.iter().map(|c| value(r, c)).sum::<f64>() / force_columns.len() as f64
            })
            .collect(),
    );
    let exact = |v: f64| Value {
        value: v,
        error: 0.0,
    };
    (
        vec![
            measure("r", radius, exact(r0)),
            measure("f", force, exact(f0)),
        ],
        format!(
            "sigma = {sigma}, r0 = {r0:.4}, f0 = {f0:.4}; medians over {} frames",
            late.len()
        ),
    )
}

/// Measures every case (finished ones; others are reported with their
/// status) against its problem's reference.
pub fn evaluate(study: &Study, cases: &[Case], peers: &[PeerRun], out: &Path) -> StudyReport {
    let mut problems = Vec::new();
    for (p, problem) in study.problems.iter().enumerate() {
        let mine: Vec<&Case> = cases.iter().filter(|c| c.problem == p).collect();
        if mine.is_empty() {
            continue;
        }
        let mut runs = Vec::new();
        for case in &mine {
            let dir = out.join(&case.dir);
            // A directory left from other settings is not this case's result.
            let run = if crate::study::is_done(study, case, out) {
                read_run(&dir)
            } else {
                Err("not run with these settings".to_string())
            };
            runs.push((case, dir.clone(), run));
        }
        // Each case's resolution: the rung's h, else the problem's rule.
        let h_of = |case: &Case, run: &Result<RunData, String>| {
            problem.rungs[case.rung].h.unwrap_or_else(|| match run {
                Ok(d) => match problem.resolution {
                    Resolution::Vertices => 1.0 / d.vertices.sqrt(),
                    Resolution::MeanStep => d.summary.simulated_time / d.summary.iterations as f64,
                },
                Err(_) => f64::NAN,
            })
        };
        // FinestRung: the reference is the finished case with the smallest h.
        let finest = match problem.reference {
            Reference::FinestRung(q) => runs
                .iter()
                .filter(|(c, _, r)| {
                    r.as_ref().is_ok_and(|d| status(d) == "completed") && h_of(c, r).is_finite()
                })
                .min_by(|a, b| h_of(a.0, &a.2).total_cmp(&h_of(b.0, &b.2)))
                .map(|(c, _, r)| {
                    let d = r.as_ref().expect("filtered to finished runs");
                    (c.rung, quantity(&d.summary, q))
                }),
            _ => None,
        };
        let mut results = Vec::new();
        for (case, dir, run) in &runs {
            let rung = &problem.rungs[case.rung];
            let (data, mut st) = match run {
                Ok(d) => (Some(d), status(d)),
                Err(e) => (None, format!("failed: {e}")),
            };
            let vertices = data.map_or(f64::NAN, |d| d.vertices);
            let iterations = data.map_or(0, |d| d.summary.iterations);
            let wall = data.map_or(f64::NAN, |d| d.summary.wall_time_s);
            let kappa = bending_kappa(&case.scene).unwrap_or(f64::NAN);
            let mut measurements = Vec::new();
            let mut note = String::new();
            if let Some(d) = data.filter(|_| st == "completed") {
                match problem.reference {
                    Reference::SphereBending | Reference::SpheroidBending => {
                        if let Some(exact) = static_reference(problem.reference, case) {
                            measurements.push(measure("E_b", d.initial_bending, exact));
                        }
                    }
                    Reference::Axisymmetric => match axisymmetric_measurements(
                        &dir.join("final.ply"),
                        final_bending(&d.summary),
                        d.summary.last.area,
                        d.summary.last.reduced_volume,
                        kappa,
                    ) {
                        Ok((m, n)) => {
                            (measurements, note) = (m, format!("{n}; {}", equilibration(&d.rows)))
                        }
                        // E.g. a run that ends outside the solver's range
                        // of v: the case stays in the table, unmeasured.
                        Err(reason) => st = format!("not measured: {reason}"),
                    },
                    Reference::Tether => (measurements, note) = tether_measurements(&case.scene, d),
                    Reference::FinestRung(q) => {
                        if let Some((_, value)) = finest {
                            measurements.push(measure(
                                q.name(),
                                quantity(&d.summary, q),
                                Value { value, error: 0.0 },
                            ));
                        }
                    }
                }
            }
            let h = h_of(case, run);
            results.push(CaseResult {
                engine: "remembrane".into(),
                rung: rung.label.clone(),
                h,
                vertices: if vertices.is_finite() {
                    vertices as usize
                } else {
                    0
                },
                iterations,
                simulated_time: data.map_or(f64::NAN, |d| d.summary.simulated_time),
                wall_s: wall,
                cost_s: match data {
                    Some(d) if problem.reference.is_static() => {
                        systems_time(&d.summary.timings) / iterations.max(1) as f64
                    }
                    _ => wall,
                },
                status: st,
                is_reference: finest.is_some_and(|(r, _)| r == case.rung),
                measurements,
                note,
            });
        }
        let order = if problem.fit_order {
            fit_order(&results)
        } else {
            None
        };
        let cheapest = ERROR_TARGETS
            .iter()
            .map(|&target| Cheapest {
                target,
                rung: results
                    .iter()
                    .filter(|c| c.worst_error().is_some_and(|e| e <= target))
                    .min_by(|a, b| a.cost_s.total_cmp(&b.cost_s))
                    .map(|c| (c.rung.clone(), c.cost_s)),
            })
            .collect();
        let mut peer_results = Vec::new();
        for run in peers.iter().filter(|r| r.problem == p) {
            let Some(case) = mine.iter().find(|c| c.rung == run.rung) else {
                continue;
            };
            let rung = &problem.rungs[run.rung];
            let (status, measurements, note, output) = match &run.result {
                Ok(o) => match peer_measurements(problem.reference, case, o) {
                    Ok((m, note)) => ("completed".to_string(), m, note, Some(o)),
                    Err(e) => (format!("failed: {e}"), Vec::new(), String::new(), Some(o)),
                },
                Err(e) => (format!("failed: {e}"), Vec::new(), String::new(), None),
            };
            let vertices = output.map_or(0, |o| o.vertices);
            peer_results.push(CaseResult {
                engine: run.peer.clone(),
                rung: rung.label.clone(),
                h: rung.h.unwrap_or(1.0 / (vertices as f64).sqrt()),
                vertices,
                iterations: 0,
                simulated_time: f64::NAN,
                wall_s: output.map_or(f64::NAN, |o| o.wall_s),
                cost_s: output.map_or(f64::NAN, |o| o.cost_s),
                status,
                is_reference: false,
                measurements,
                note: [note, output.map(|o| o.notes.clone()).unwrap_or_default()]
                    .into_iter()
                    .filter(|n| !n.is_empty())
                    .collect::<Vec<_>>()
                    .join("; "),
            });
        }
        problems.push(ProblemResult {
            name: problem.name.clone(),
            description: problem.description.clone(),
            cost_label: if problem.reference.is_static() {
                "systems' time per iteration (s)".into()
            } else {
                "wall time of the run (s)".into()
            },
            h_label: match problem.resolution {
                _ if problem.rungs.iter().all(|r| r.h.is_some()) => {
                    "h (as declared by the rungs)".into()
                }
                Resolution::Vertices => "h = N^(-1/2) (N vertices)".into(),
                Resolution::MeanStep => "mean time step (s)".into(),
            },
            cases: results,
            peers: peer_results,
            quoted: problem.quoted.clone(),
            order,
            cheapest,
        });
    }
    StudyReport {
        name: study.name.clone(),
        problems,
    }
}

/// Time spent in the systems that step the membrane (s): every stage but
/// Observe (frames, series rows), so scene building and output are left
/// out. The force terms count through their system's own row (`part_of`
/// rows are parts of a system and may overlap in time).
fn systems_time(timings: &[crate::engine::schedule::SystemTiming]) -> f64 {
    if timings.is_empty() {
        return f64::NAN;
    }
    timings
        .iter()
        .filter(|s| s.stage != "Observe" && s.part_of.is_none())
        .map(|s| s.total_s)
        .sum()
}

fn status(d: &RunData) -> String {
    match d.summary.status {
        crate::workflow::run::RunStatus::Completed => "completed",
        crate::workflow::run::RunStatus::BlewUp => "blew_up",
    }
    .to_string()
}

/// Least-squares slope of ln(primary error) against ln(h).
pub fn fit_order(cases: &[CaseResult]) -> Option<Order> {
    let points: Vec<(f64, f64)> = cases
        .iter()
        .filter_map(|c| {
            let e = c.primary_error()?;
            (e > 0.0 && c.h > 0.0 && c.h.is_finite()).then(|| (c.h.ln(), e.ln()))
        })
        .collect();
    let n = points.len();
    if n < 2 {
        return None;
    }
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n as f64;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let slope = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx;
    let residual: f64 = points
        .iter()
        .map(|p| (p.1 - my - slope * (p.0 - mx)).powi(2))
        .sum();
    let std_error = if n > 2 {
        (residual / (n - 2) as f64 / sxx).sqrt()
    } else {
        f64::NAN
    };
    Some(Order {
        p: slope,
        std_error,
        points: n,
        centroid: (mx.exp(), my.exp()),
    })
}

/// Points not dominated in (cost, error): no other case is both cheaper
/// and at least as accurate. Sorted by cost.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut sorted: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for p in sorted {
        if front.last().is_none_or(|last| p.1 < last.1) {
            front.push(p);
        }
    }
    front
}

fn sig(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    format!("{v:.3e}")
}

/// The Markdown report.
pub fn markdown(report: &StudyReport) -> String {
    let mut s = format!("# Study `{}`: speed against error\n\n", report.name);
    for p in &report.problems {
        s += &format!("## {}\n\n", p.name);
        if !p.description.is_empty() {
            s += &format!("{}\n\n", p.description);
        }
        let quantities: Vec<String> = p
            .cases
            .iter()
            .find(|c| !c.measurements.is_empty())
            .map(|c| c.measurements.iter().map(|m| m.quantity.clone()).collect())
            .unwrap_or_default();
        s += "| engine | rung | N | h | iterations | wall (s) | cost (s) |";
        for q in &quantities {
            s += &format!(" {q} | error |");
        }
        s += " status |\n|---|---|---:|---:|---:|---:|---:|";
        for _ in &quantities {
            s += "---:|---:|";
        }
        s += "---|\n";
        for c in p.cases.iter().chain(&p.peers) {
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} |",
                c.engine,
                c.rung,
                c.vertices,
                sig(c.h),
                c.iterations,
                if c.wall_s.is_finite() {
                    format!("{:.3}", c.wall_s)
                } else {
                    "–".into()
                },
                sig(c.cost_s)
            );
            for k in 0..quantities.len() {
                match c.measurements.get(k) {
                    Some(m) if c.is_reference => {
                        s += &format!(" {:.6} | (reference) |", m.measured)
                    }
                    Some(m) => s += &format!(" {:.6} | {} |", m.measured, sig(m.error)),
                    None => s += " – | – |",
                }
            }
            s += &format!(" {} |\n", c.status);
        }
        for q in &p.quoted {
            s += &format!(
                "| {} | {} | {} | – | {} | {:.0} | – |{} quoted: {} |\n",
                q.engine,
                q.rung,
                q.vertices,
                q.iterations,
                q.wall_s,
                " – | – |".repeat(quantities.len()),
                q.source
            );
        }
        let reference_line = |c: &CaseResult| {
            c.measurements
                .iter()
                .map(|m| {
                    if m.reference_error > 0.0 {
                        format!(
                            "{} = {:.6} ± {:.1e}",
                            m.quantity, m.reference, m.reference_error
                        )
                    } else {
                        format!("{} = {:.6}", m.quantity, m.reference)
                    }
                })
                .collect::<Vec<String>>()
                .join(", ")
        };
        let measured: Vec<&CaseResult> = p
            .cases
            .iter()
            .filter(|c| !c.measurements.is_empty())
            .collect();
        let lines: Vec<String> = measured.iter().map(|c| reference_line(c)).collect();
        let noted = measured.iter().any(|c| !c.note.is_empty());
        if !noted && lines.windows(2).all(|w| w[0] == w[1]) {
            if let Some(line) = lines.first() {
                s += &format!("\nReference: {line}.\n");
            }
        } else {
            s += "\nReference per case (each at the case's own state):\n";
            for (c, line) in measured.iter().zip(&lines) {
                let note = if c.note.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", c.note)
                };
                s += &format!("- `{}`: {line}{note}\n", c.rung);
            }
        }
        let mut noted = std::collections::BTreeSet::new();
        for c in &p.peers {
            if !c.note.is_empty() && noted.insert((c.engine.clone(), c.note.clone())) {
                s += &format!("- {} `{}`: {}\n", c.engine, c.rung, c.note);
            }
        }
        match p.order {
            Some(o) if o.std_error.is_finite() => {
                s += &format!(
                    "Observed order of the {} error: p = {:.2} ± {:.2} ({} points; error ∝ h^p, {}).\n",
                    quantities.first().map_or("", String::as_str),
                    o.p,
                    o.std_error,
                    o.points,
                    p.h_label
                )
            }
            Some(o) => {
                s += &format!(
                    "Observed order: p = {:.2} (2 points; {}).\n",
                    o.p, p.h_label
                )
            }
            None => {
                s += "Observed order: not fitted (turned off, or fewer than two measured cases).\n"
            }
        }
        for c in &p.cheapest {
            match &c.rung {
                Some((rung, cost)) => {
                    s += &format!(
                        "- every error ≤ {:.0e}: `{rung}`, {} ({})\n",
                        c.target,
                        sig(*cost),
                        p.cost_label
                    )
                }
                None => s += &format!("- every error ≤ {:.0e}: not reached\n", c.target),
            }
        }
        s += "\n";
    }
    s
}

/// The long-format CSV: one row per (case, quantity).
pub fn csv(report: &StudyReport) -> String {
    let mut s = String::from(
        "engine,problem,rung,h,vertices,iterations,simulated_time_s,wall_s,cost_s,status,is_reference,quantity,measured,reference,reference_error,relative_error\n",
    );
    for p in &report.problems {
        for c in p.cases.iter().chain(&p.peers) {
            let head = format!(
                "{},{},{},{:e},{},{},{:e},{:e},{:e},{},{}",
                c.engine,
                p.name,
                c.rung,
                c.h,
                c.vertices,
                c.iterations,
                c.simulated_time,
                c.wall_s,
                c.cost_s,
                c.status.replace(',', ";"),
                c.is_reference
            );
            if c.measurements.is_empty() {
                s += &format!("{head},,,,,\n");
            }
            for m in &c.measurements {
                s += &format!(
                    "{head},{},{:e},{:e},{:e},{:e}\n",
                    m.quantity, m.measured, m.reference, m.reference_error, m.error
                );
            }
        }
    }
    s
}

/// One triangle-marked series per peer: (x(case), primary error).
fn peer_series(p: &ProblemResult, x: fn(&CaseResult) -> f64) -> Vec<Series> {
    let mut names: Vec<&str> = Vec::new();
    for c in &p.peers {
        if !names.contains(&c.engine.as_str()) {
            names.push(&c.engine);
        }
    }
    names
        .iter()
        .enumerate()
        .map(|(k, name)| Series {
            name: (*name).to_string(),
            points: p
                .peers
                .iter()
                .filter(|c| c.engine == *name)
                .filter_map(|c| Some((x(c), c.primary_error()?)))
                .collect(),
            markers: true,
            marker: Marker::Triangle,
            // Not the Pareto front's colour (3).
            color: [2, 4, 5][k % 3],
            ..Default::default()
        })
        .collect()
}

/// The charts of one problem: error against cost with the Pareto front,
/// and error against h with the fitted order.
pub fn charts(p: &ProblemResult) -> [(String, Vec<u8>); 2] {
    let quantity = p
        .cases
        .iter()
        .find_map(|c| c.measurements.first())
        .map_or("error".to_string(), |m| {
            format!("relative error of {}", m.quantity)
        });
    let points: Vec<(f64, f64)> = p
        .cases
        .iter()
        .filter_map(|c| Some((c.cost_s, c.primary_error()?)))
        .collect();
    let cost = Chart {
        title: format!("{}: error against cost", p.name),
        x_label: p.cost_label.clone(),
        y_label: quantity.clone(),
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series: vec![
            Series {
                name: "remembrane".into(),
                points: points.clone(),
                markers: true,
                ..Default::default()
            },
            Series {
                name: "Pareto front".into(),
                points: pareto_front(&points),
                lines: true,
                color: 3,
                ..Default::default()
            },
        ]
        .into_iter()
        .chain(peer_series(p, |c| c.cost_s))
        .collect(),
        // Dominated points (expensive and inexact) sit upper right.
        legend: Legend::LowerLeft,
    };
    let by_h: Vec<(f64, f64)> = p
        .cases
        .iter()
        .filter_map(|c| Some((c.h, c.primary_error()?)))
        .collect();
    let mut series = vec![Series {
        name: "remembrane".into(),
        points: by_h.clone(),
        markers: true,
        ..Default::default()
    }];
    if let Some(o) = p.order {
        // The fitted line through the fitted points' centroid in log-log.
        let (cx, cy) = o.centroid;
        let (lo, hi) = by_h
            .iter()
            .filter(|q| q.0 > 0.0 && q.1 > 0.0)
            .fold((f64::INFINITY, 0.0f64), |(a, b), q| {
                (a.min(q.0), b.max(q.0))
            });
        let line = |h: f64| (h, cy * (h / cx).powf(o.p));
        series.push(Series {
            name: format!("fit: p = {:.2}", o.p),
            points: vec![line(lo), line(hi)],
            lines: true,
            color: 1,
            ..Default::default()
        });
    }
    series.extend(peer_series(p, |c| c.h));
    let resolution = Chart {
        title: format!("{}: convergence", p.name),
        x_label: p.h_label.clone(),
        y_label: quantity,
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series,
        legend: Legend::LowerRight,
    };
    [
        (
            format!("{}_error_vs_cost.png", p.name),
            crate::io::plot::chart(&cost),
        ),
        (
            format!("{}_error_vs_h.png", p.name),
            crate::io::plot::chart(&resolution),
        ),
    ]
}

/// Writes `study.csv`, `study.md`, `study.json` and the charts into `out`.
pub fn write_report(report: &StudyReport, out: &Path) -> Result<(), StudyError> {
    let write = |name: &str, bytes: &[u8]| {
        let path = out.join(name);
        crate::atomic_write(&path, bytes).map_err(|e| StudyError::Output {
            path: path.clone(),
            reason: e.to_string(),
        })
    };
    write("study.csv", csv(report).as_bytes())?;
    write("study.md", markdown(report).as_bytes())?;
    let json = serde_json::to_string_pretty(report).expect("the report serialises");
    write("study.json", json.as_bytes())?;
    for p in &report.problems {
        for (name, png) in charts(p) {
            write(&name, &png)?;
        }
    }
    Ok(())
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
