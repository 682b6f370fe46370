//! Evaluating a study: every case measured, the observed order, the Pareto
//! front of cost against error.

use super::*;
use crate::study::Problem;
use std::path::PathBuf;

/// A case with its run directory and its run's data, or why it has none.
type CaseRun<'a> = (&'a Case, PathBuf, Result<RunData, MeasureError>);

/// Measures every case (finished ones; others are reported with their
/// status) against its problem's reference.
pub fn evaluate(study: &Study, cases: &[Case], peers: &[PeerRun], out: &Path) -> StudyReport {
    let mut problems = Vec::new();
    for (p, problem) in study.problems.iter().enumerate() {
        let mine: Vec<&Case> = cases.iter().filter(|c| c.problem == p).collect();
        if mine.is_empty() {
            continue;
        }
        let runs = read_case_runs(study, &mine, out);
        let finest = finest_rung(problem, &runs);
        let results: Vec<CaseResult> = runs
            .iter()
            .map(|run| case_result(problem, run, finest))
            .collect();
        let order = if problem.fit_order {
            fit_order(&results)
        } else {
            None
        };
        let cheapest = cheapest_per_target(&results);
        let peer_results = peer_results(problem, p, &mine, peers);
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

/// Each case of `mine` with its run directory under `out` and its run's
/// data, if it was run with the study's current settings.
fn read_case_runs<'a>(study: &Study, mine: &[&'a Case], out: &Path) -> Vec<CaseRun<'a>> {
    let mut runs = Vec::new();
    for case in mine {
        let dir = out.join(&case.dir);
        // A directory left from other settings is not this case's result.
        let run = if crate::study::is_done(study, case, out) {
            read_run(&dir)
        } else {
            Err(MeasureError::NotRun)
        };
        runs.push((*case, dir.clone(), run));
    }
    runs
}

/// A case's resolution: its rung's h, else the problem's rule (NaN for a
/// case without data).
fn case_h(problem: &Problem, case: &Case, run: &Result<RunData, MeasureError>) -> f64 {
    problem.rungs[case.rung].h.unwrap_or_else(|| match run {
        Ok(d) => match problem.resolution {
            Resolution::Vertices => 1.0 / d.vertices.sqrt(),
            Resolution::MeanStep => d.summary.simulated_time / d.summary.iterations as f64,
        },
        Err(_) => f64::NAN,
    })
}

/// For a `FinestRung` problem, the reference: the rung of the finished
/// case with the smallest h, and its quantity.
fn finest_rung(problem: &Problem, runs: &[CaseRun<'_>]) -> Option<(usize, f64)> {
    match problem.reference {
        Reference::FinestRung(q) => runs
            .iter()
            .filter(|(c, _, r)| {
                r.as_ref().is_ok_and(|d| status(d) == "completed")
                    && case_h(problem, c, r).is_finite()
            })
            .min_by(|a, b| case_h(problem, a.0, &a.2).total_cmp(&case_h(problem, b.0, &b.2)))
            .map(|(c, _, r)| {
                let d = r.as_ref().expect("filtered to finished runs");
                (c.rung, quantity(&d.summary, q))
            }),
        _ => None,
    }
}

/// One case's result: its run's figures and, if it completed, its
/// measurements against the problem's reference (`finest`: the
/// `FinestRung` reference's rung and value).
fn case_result(
    problem: &Problem,
    (case, dir, run): &CaseRun<'_>,
    finest: Option<(usize, f64)>,
) -> CaseResult {
    let rung = &problem.rungs[case.rung];
    let (data, mut st) = match run {
        Ok(d) => (Some(d), status(d)),
        Err(e) => (None, format!("failed: {e}")),
    };
    let vertices = data.map_or(f64::NAN, |d| d.vertices);
    let iterations = data.map_or(0, |d| d.summary.iterations);
    let wall = data.map_or(f64::NAN, |d| d.summary.wall_time_s);
    let mut measurements = Vec::new();
    let mut note = String::new();
    if let Some(d) = data.filter(|_| st == "completed") {
        match case_measurements(problem, case, dir, d, finest) {
            Ok(m) => (measurements, note) = m,
            Err(reason) => st = format!("not measured: {reason}"),
        }
    }
    CaseResult {
        engine: "remembrane".into(),
        rung: rung.label.clone(),
        h: case_h(problem, case, run),
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
    }
}

/// The measurements and note of a completed case (run data `d`, run
/// directory `dir`) against its problem's reference, or why it could not
/// be measured.
fn case_measurements(
    problem: &Problem,
    case: &Case,
    dir: &Path,
    d: &RunData,
    finest: Option<(usize, f64)>,
) -> Result<(Vec<Measurement>, String), MeasureError> {
    let mut measurements = Vec::new();
    let mut note = String::new();
    match problem.reference {
        Reference::SphereBending | Reference::SpheroidBending => {
            if let Some(exact) = static_reference(problem.reference, case) {
                measurements.push(measure("E_b", d.initial_bending, exact));
            }
        }
        Reference::Axisymmetric => {
            let kappa = case.scene.bending_kappa().unwrap_or(f64::NAN);
            // Err, e.g., for a run that ends outside the solver's range of
            // v: the case stays in the table, unmeasured.
            let (m, n) = axisymmetric_measurements(
                &dir.join("final.ply"),
                final_bending(&d.summary),
                d.summary.last.area,
                d.summary.last.reduced_volume.unwrap_or(f64::NAN),
                kappa,
            )?;
            (measurements, note) = (m, format!("{n}; {}", equilibration(&d.rows)));
        }
        Reference::Tether => (measurements, note) = tether_measurements(&case.scene, d),
        Reference::Adhesion => {
            (measurements, note) =
                adhesion_measurements(&case.scene, &dir.join("final.ply"), &d.summary)?;
        }
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
    Ok((measurements, note))
}

/// Per error target, the cheapest case whose every measurement reaches it.
fn cheapest_per_target(results: &[CaseResult]) -> Vec<Cheapest> {
    ERROR_TARGETS
        .iter()
        .map(|&target| Cheapest {
            target,
            rung: results
                .iter()
                .filter(|c| c.worst_error().is_some_and(|e| e <= target))
                .min_by(|a, b| a.cost_s.total_cmp(&b.cost_s))
                .map(|c| (c.rung.clone(), c.cost_s)),
        })
        .collect()
}

/// The peers' results on problem `p` (whose cases are `mine`), run by run.
fn peer_results(problem: &Problem, p: usize, mine: &[&Case], peers: &[PeerRun]) -> Vec<CaseResult> {
    let mut peer_results = Vec::new();
    for run in peers.iter().filter(|r| r.problem == p) {
        let Some(case) = mine.iter().find(|c| c.rung == run.rung) else {
            continue;
        };
        peer_results.push(peer_result(problem, case, run));
    }
    peer_results
}

/// One peer run's result on `case`, measured against the problem's
/// reference.
fn peer_result(problem: &Problem, case: &Case, run: &PeerRun) -> CaseResult {
    let rung = &problem.rungs[run.rung];
    let (status, measurements, note, output) = match &run.result {
        Ok(o) => match peer_measurements(problem.reference, case, o) {
            Ok((m, note)) => ("completed".to_string(), m, note, Some(o)),
            Err(e) => (format!("failed: {e}"), Vec::new(), String::new(), Some(o)),
        },
        Err(e) => (format!("failed: {e}"), Vec::new(), String::new(), None),
    };
    let vertices = output.map_or(0, |o| o.vertices);
    CaseResult {
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
    }
}

/// Time spent in the systems that step the membrane (s): every stage but
/// Observe (frames, series rows), so scene building and output are left
/// out. The force terms count through their system's own row (`part_of`
/// rows are parts of a system and may overlap in time).
pub(super) fn systems_time(timings: &[crate::engine::schedule::SystemTiming]) -> f64 {
    if timings.is_empty() {
        return f64::NAN;
    }
    timings
        .iter()
        .filter(|s| s.stage != "Observe" && s.part_of.is_none())
        .map(|s| s.total_s)
        .sum()
}

pub(super) fn status(d: &RunData) -> String {
    match d.summary.status {
        crate::io::summary::RunStatus::Completed => "completed",
        crate::io::summary::RunStatus::BlewUp => "blew_up",
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
