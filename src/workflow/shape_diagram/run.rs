//! Running a diagram: every branch walked on every mesh, its points against
//! the continuum's, the crossings and the extrapolation.

use super::*;

/// Options of a diagram run.
#[derive(Clone, Debug)]
pub struct DiagramOptions {
    /// Replace the output directory if it exists.
    pub overwrite: bool,
    /// Walk only the meshes with these labels (default: all).
    pub meshes: Option<Vec<String>>,
    /// Override every point's iteration cap (quick trials).
    pub iterations: Option<u64>,
    /// Print a line per point.
    pub progress: bool,
}

/// A reference value with its Richardson error bar.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceValue {
    /// E_b/8πκ of the continuum.
    pub energy: f64,
    /// Its error bar.
    pub error: f64,
    /// Δp R0³/κ.
    pub pressure: f64,
    /// σ R0²/κ.
    pub tension: f64,
}

/// One point of the diagram.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiagramPoint {
    /// The mesh's label.
    pub mesh: String,
    /// The branch's name.
    pub branch: String,
    /// Its reference branch.
    pub reference_branch: Branch,
    /// The reduced volume asked for.
    pub target: f64,
    /// `completed`, `failed: <reason>` or `not reached` (an earlier point
    /// of the walk failed).
    pub status: String,
    /// Vertices at the end.
    pub vertices: usize,
    /// Reduced volume reached.
    pub reduced_volume: f64,
    /// E_b/8πκ of the mesh.
    pub energy: f64,
    /// Δp R0³/κ of the mesh (from the volume constraint's multiplier).
    pub pressure: f64,
    /// σ R0²/κ of the mesh (from the area constraint's multiplier).
    pub tension: f64,
    /// The shape's class (`summary.json` `shape.class`).
    pub class: String,
    /// Whether a convergence criterion of the minimiser held.
    pub converged: bool,
    /// What ended the minimisation.
    pub stopped_by: String,
    /// Minimiser iterations.
    pub iterations: u64,
    /// Remesh events.
    pub remesh_events: u64,
    /// Wall time (s).
    pub wall_time_s: f64,
    /// The continuum at `target` (none when the reference branch has no
    /// solution there, or references were skipped).
    pub reference: Option<ReferenceValue>,
    /// (energy − reference) / reference.
    pub relative_error: Option<f64>,
}

/// Where two branches have equal energy.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Crossing {
    /// The mesh's label, or `continuum`.
    pub mesh: String,
    /// The two branches.
    pub branches: (String, String),
    /// v of equal energy (linear interpolation between walked points, or
    /// the reference solver's root).
    pub reduced_volume: f64,
    /// E_b/8πκ there.
    pub energy: f64,
}

/// A branch's energy at one reduced volume extrapolated to h → 0.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExtrapolatedPoint {
    /// The branch's name.
    pub branch: String,
    /// The reduced volume asked for.
    pub target: f64,
    /// The two meshes (coarse, fine).
    pub meshes: (String, String),
    /// E_f + (E_f − E_c)/((h_c/h_f)² − 1).
    pub energy: f64,
    /// The continuum's E_b/8πκ, if known.
    pub reference: Option<f64>,
    /// (energy − reference) / reference.
    pub relative_error: Option<f64>,
}

/// Order-2 Richardson extrapolation of every branch point from the two
/// finest meshes that declare `h`.
pub(super) fn extrapolate(
    meshes: &[DiagramMesh],
    points: &[DiagramPoint],
) -> Vec<ExtrapolatedPoint> {
    let mut rungs: Vec<(&str, f64)> = meshes
        .iter()
        .filter_map(|m| m.h.map(|h| (m.label.as_str(), h)))
        .filter(|(l, _)| points.iter().any(|p| p.mesh == *l))
        .collect();
    rungs.sort_by(|a, b| b.1.total_cmp(&a.1));
    let [.., (coarse, hc), (fine, hf)] = rungs[..] else {
        return Vec::new();
    };
    let factor = (hc / hf).powi(2) - 1.0;
    points
        .iter()
        .filter(|f| f.mesh == fine && f.status == "completed")
        .filter_map(|f| {
            let c = points.iter().find(|c| {
                c.mesh == coarse
                    && c.branch == f.branch
                    && c.target == f.target
                    && c.status == "completed"
            })?;
            let energy = f.energy + (f.energy - c.energy) / factor;
            let reference = f.reference.map(|r| r.energy);
            Some(ExtrapolatedPoint {
                branch: f.branch.clone(),
                target: f.target,
                meshes: (coarse.to_string(), fine.to_string()),
                energy,
                reference,
                relative_error: reference.map(|r| (energy - r) / r),
            })
        })
        .collect()
}

/// `diagram.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DiagramSummary {
    /// The diagram's name.
    pub name: String,
    /// The diagram file.
    pub file: PathBuf,
    /// Every point, walk by walk.
    pub points: Vec<DiagramPoint>,
    /// Crossings of the measured branches and of the continuum's.
    pub crossings: Vec<Crossing>,
    /// Richardson extrapolation (order 2) of each branch's energy from the
    /// two finest meshes that declare `h`, where both completed.
    pub extrapolated: Vec<ExtrapolatedPoint>,
    /// The continuum curves drawn (branch, [(v, E_b/8πκ)]).
    pub curves: Vec<(Branch, Vec<(f64, f64)>)>,
    /// Wall time of the whole diagram (s).
    pub wall_time_s: f64,
}

/// Segments of the axisymmetric curves drawn under the points.
pub(super) const CURVE_SEGMENTS: usize = 200;
/// Spacing of the drawn curves in v.
pub(super) const CURVE_STEP: f64 = 0.005;

/// The directory name of the point at `v`.
pub(super) fn point_dir(v: f64) -> String {
    format!("v{v}")
}

/// Runs the diagram into `out` (staged as `out.incomplete`).
pub fn run_diagram(
    loaded: &LoadedDiagram,
    out: &Path,
    options: &DiagramOptions,
) -> Result<DiagramSummary, DiagramError> {
    let started = std::time::Instant::now();
    if let Some(labels) = &options.meshes
        && let Some(l) = labels
            .iter()
            .find(|l| !loaded.walks.iter().any(|w| &&w.mesh == l))
    {
        return Err(DiagramError::File {
            path: loaded.path.clone(),
            reason: format!("--meshes: no mesh `{l}` in field `meshes`"),
        });
    }
    let staging =
        crate::io::output::prepare_staging(out, options.overwrite).map_err(|e| match e {
            crate::io::output::OutputError::Exists(dir) => DiagramError::Exists(dir),
            crate::io::output::OutputError::Write { path, reason } => {
                DiagramError::Io { path, reason }
            }
        })?;
    let walks: Vec<&Walk> = loaded
        .walks
        .iter()
        .filter(|w| options.meshes.as_ref().is_none_or(|m| m.contains(&w.mesh)))
        .collect();
    let references = continuum_references(&walks);
    let mut points = Vec::new();
    for w in &walks {
        run_walk(w, &staging, &references, options, &mut points);
    }
    let curves = reference_curves(&walks);
    let crossings = crossings(&points, &curves);
    let extrapolated = extrapolate(&loaded.diagram.meshes, &points);
    let summary = DiagramSummary {
        name: loaded.diagram.name.clone(),
        file: loaded.path.clone(),
        points,
        crossings,
        extrapolated,
        curves,
        wall_time_s: started.elapsed().as_secs_f64(),
    };
    publish(summary, staging, out)
}

/// The continuum at every point of `walks`, branch by branch: (reference
/// branch, reduced volume, value if the solver converged there).
fn continuum_references(walks: &[&Walk]) -> Vec<(Branch, f64, Option<ReferenceValue>)> {
    let mut references: Vec<(Branch, f64, Option<ReferenceValue>)> = Vec::new();
    for w in walks {
        for &(v, _) in &w.points {
            if references
                .iter()
                .any(|(b, rv, _)| *b == w.reference && *rv == v)
            {
                continue;
            }
            let value = axisymmetric::converged_on_branch(v, w.reference)
                .ok()
                .and_then(|c| {
                    let finest = c.levels.last()?;
                    Some(ReferenceValue {
                        energy: c.energy_over_8pi_kappa.value,
                        error: c.energy_over_8pi_kappa.error,
                        pressure: finest.pressure,
                        tension: finest.tension,
                    })
                });
            references.push((w.reference, v, value));
        }
    }
    references
}

/// Runs the points of walk `w` in order into `staging`, each from the
/// final state of the one before, and pushes them onto `points`; after a
/// failed point the rest are `not reached`.
fn run_walk(
    w: &Walk,
    staging: &Path,
    references: &[(Branch, f64, Option<ReferenceValue>)],
    options: &DiagramOptions,
    points: &mut Vec<DiagramPoint>,
) {
    let mut from: Option<PathBuf> = None;
    let mut failed = false;
    for (v, scene) in &w.points {
        let dir = staging.join(&w.mesh).join(&w.branch).join(point_dir(*v));
        let reference = references
            .iter()
            .find(|(rb, rv, _)| *rb == w.reference && *rv == *v)
            .and_then(|(_, _, r)| *r);
        let mut point = unreached_point(w, *v, reference);
        if failed {
            points.push(point);
            continue;
        }
        let run_options = RunOptions {
            overwrite: true,
            iterations: options.iterations,
            from: from.clone(),
            ..RunOptions::quiet(dir.clone())
        };
        match run_scene(scene, &w.scene_path, &run_options, |_| Ok(())) {
            Ok(summary) => {
                fill_point(&mut point, &summary, scene);
                from = Some(dir.join("state.json"));
            }
            Err(e) => {
                point.status = format!("failed: {e}");
                failed = true;
            }
        }
        if options.progress {
            eprintln!("{}", progress_line(&point));
        }
        points.push(point);
    }
}

/// The point of walk `w` at `v` before it is run (`not reached`), with the
/// continuum's value there.
fn unreached_point(w: &Walk, v: f64, reference: Option<ReferenceValue>) -> DiagramPoint {
    DiagramPoint {
        mesh: w.mesh.clone(),
        branch: w.branch.clone(),
        reference_branch: w.reference,
        target: v,
        status: "not reached".into(),
        vertices: 0,
        reduced_volume: f64::NAN,
        energy: f64::NAN,
        pressure: f64::NAN,
        tension: f64::NAN,
        class: String::new(),
        converged: false,
        stopped_by: String::new(),
        iterations: 0,
        remesh_events: 0,
        wall_time_s: 0.0,
        reference,
        relative_error: None,
    }
}

/// Writes the diagram's outputs into `staging` and, if every point
/// completed, renames it to `out`; else the error names the first failure.
fn publish(
    summary: DiagramSummary,
    staging: PathBuf,
    out: &Path,
) -> Result<DiagramSummary, DiagramError> {
    let io = |path: &Path, e: std::io::Error| DiagramError::Io {
        path: path.to_owned(),
        reason: e.to_string(),
    };
    write_outputs(&staging, &summary).map_err(|(p, e)| io(&p, e))?;
    let failures: Vec<&DiagramPoint> = summary
        .points
        .iter()
        .filter(|p| p.status != "completed")
        .collect();
    if let Some(first) = failures.first() {
        return Err(DiagramError::Points {
            failed: failures.len(),
            total: summary.points.len(),
            first: format!(
                "{} {} v = {}: {}",
                first.mesh, first.branch, first.target, first.status
            ),
            dir: staging,
        });
    }
    std::fs::rename(&staging, out).map_err(|e| io(out, e))?;
    Ok(summary)
}

/// Fills a completed point from its run's summary.
pub(super) fn fill_point(point: &mut DiagramPoint, s: &RunSummary, scene: &Scene) {
    let kappa = scene.bending_kappa().unwrap_or(f64::NAN);
    let bending: f64 = s
        .last
        .energies
        .iter()
        .filter(|e| e.term == "bending")
        .map(|e| e.energy)
        .sum();
    let r0 = (s.last.area / (4.0 * std::f64::consts::PI)).sqrt();
    point.status = "completed".into();
    point.vertices = s.last.vertices;
    point.reduced_volume = s.last.reduced_volume.unwrap_or(f64::NAN);
    point.energy = bending / (8.0 * std::f64::consts::PI * kappa);
    if let Some(c) = &s.constraints {
        point.pressure = c.reactions.pressure * r0.powi(3) / kappa;
        point.tension = c.reactions.tension * r0 * r0 / kappa;
    }
    point.class = serde_json::to_value(s.shape.class)
        .ok()
        .and_then(|c| c.as_str().map(str::to_string))
        .unwrap_or_default();
    if let Some(m) = &s.minimiser {
        point.converged = m.converged;
        point.stopped_by = m.stopped_by.to_string();
    }
    point.iterations = s.iterations;
    point.remesh_events = s.remesh.events;
    point.wall_time_s = s.wall_time_s;
    point.relative_error = point
        .reference
        .map(|r| (point.energy - r.energy) / r.energy);
}

pub(super) fn progress_line(p: &DiagramPoint) -> String {
    let reference = match (p.reference, p.relative_error) {
        (Some(r), Some(e)) => format!(" (continuum {:.4}, {:+.2} %)", r.energy, 100.0 * e),
        _ => String::new(),
    };
    if p.status == "completed" {
        format!(
            "{} {} v = {}: E_b/8πκ = {:.4}{reference}, {}, {} iterations ({}), {:.2} s",
            p.mesh,
            p.branch,
            p.target,
            p.energy,
            p.class,
            p.iterations,
            p.stopped_by,
            p.wall_time_s
        )
    } else {
        format!("{} {} v = {}: {}", p.mesh, p.branch, p.target, p.status)
    }
}

/// The continuum curve of every reference branch walked, over the range
/// of its walks' reduced volumes (with a margin), where it exists.
pub(super) fn reference_curves(walks: &[&Walk]) -> Vec<(Branch, Vec<(f64, f64)>)> {
    let mut out: Vec<(Branch, Vec<(f64, f64)>)> = Vec::new();
    for w in walks {
        if out.iter().any(|(b, _)| *b == w.reference) {
            continue;
        }
        let vs = walks
            .iter()
            .filter(|x| x.reference == w.reference)
            .flat_map(|x| x.points.iter().map(|p| p.0));
        let (lo, hi) = vs.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        let (lo, hi) = ((lo - 0.02).max(0.02), (hi + 0.02).min(0.995));
        // Walked from the top, as the branches are continued.
        let steps = ((hi - lo) / CURVE_STEP).round() as usize;
        let grid: Vec<f64> = (0..=steps)
            .map(|k| hi - (hi - lo) * k as f64 / steps.max(1) as f64)
            .collect();
        let curve = axisymmetric::branch_curve(w.reference, &grid, CURVE_SEGMENTS)
            .into_iter()
            .zip(&grid)
            .filter_map(|(r, v)| r.ok().map(|s| (*v, s.energy_over_8pi_kappa)))
            .collect();
        out.push((w.reference, curve));
    }
    out
}

/// Where each pair of walked branches on a mesh, and each pair of
/// continuum curves, has equal energy (the first sign change of the
/// difference, by linear interpolation).
pub(super) fn crossings(
    points: &[DiagramPoint],
    curves: &[(Branch, Vec<(f64, f64)>)],
) -> Vec<Crossing> {
    let mut out = Vec::new();
    let mut meshes: Vec<&str> = points.iter().map(|p| p.mesh.as_str()).collect();
    meshes.dedup();
    for mesh in meshes {
        let mut branches: Vec<&str> = points
            .iter()
            .filter(|p| p.mesh == mesh)
            .map(|p| p.branch.as_str())
            .collect();
        branches.dedup();
        let series = |b: &str| -> Vec<(f64, f64)> {
            points
                .iter()
                .filter(|p| p.mesh == mesh && p.branch == b && p.status == "completed")
                .map(|p| (p.target, p.energy))
                .collect()
        };
        for (i, a) in branches.iter().enumerate() {
            for b in &branches[i + 1..] {
                if let Some((v, e)) = crossing(&series(a), &series(b)) {
                    out.push(Crossing {
                        mesh: mesh.to_string(),
                        branches: (a.to_string(), b.to_string()),
                        reduced_volume: v,
                        energy: e,
                    });
                }
            }
        }
    }
    for (i, (a, ca)) in curves.iter().enumerate() {
        for (b, cb) in &curves[i + 1..] {
            if let Some((v, e)) = crossing(ca, cb) {
                out.push(Crossing {
                    mesh: "continuum".into(),
                    branches: (a.to_string(), b.to_string()),
                    reduced_volume: v,
                    energy: e,
                });
            }
        }
    }
    out
}

/// The first v (walking down) where two curves sampled at common reduced
/// volumes have equal values, by linear interpolation.
pub(super) fn crossing(a: &[(f64, f64)], b: &[(f64, f64)]) -> Option<(f64, f64)> {
    let mut common: Vec<(f64, f64, f64)> = a
        .iter()
        .filter_map(|&(v, ea)| {
            b.iter()
                .find(|(w, _)| (w - v).abs() < 1e-9)
                .map(|&(_, eb)| (v, ea, eb))
        })
        .collect();
    common.sort_by(|x, y| y.0.total_cmp(&x.0));
    common.windows(2).find_map(|w| {
        let (v0, a0, b0) = w[0];
        let (v1, a1, b1) = w[1];
        let (d0, d1) = (a0 - b0, a1 - b1);
        (d0 * d1 <= 0.0 && d0 != d1).then(|| {
            let t = d0 / (d0 - d1);
            (v0 + t * (v1 - v0), a0 + t * (a1 - a0))
        })
    })
}
