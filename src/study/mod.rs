//! Speed against error: `remembrane study STUDY.ron` runs a ladder of
//! settings on reference problems whose answers do not come from the engine,
//! and reports each case's wall time and error (issue 12).
//!
//! A study file names problems. Each problem has a scene (relative to the
//! study file), a [`Reference`] and a ladder of [`Rung`]s: settings applied
//! to the scene by dotted path (`membrane.Icosphere.level`,
//! `dynamics.dt_max`, ...), a label and optionally the resolution `h` the
//! rung stands for. Every (problem, rung) is a case, run as a normal run
//! directory `OUT/cases/<problem>/<rung>/`; a case that has finished from
//! the same scene (its `case.json`) is not run again, so an interrupted
//! study resumes and a changed rung runs anew.
//! `--quick` keeps only the rungs each problem lists in `quick`.
//!
//! After the runs, [`crate::study::report`] measures each case against its
//! reference, fits the observed convergence order and writes `study.csv`,
//! `study.md`, `study.json` and the charts.

mod load;
pub mod peer;
pub mod reference;
pub mod report;

use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A study file.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Study {
    /// Name (the default output directory is `out/<name>`).
    pub name: String,
    /// The reference problems, in order.
    pub problems: Vec<Problem>,
    /// Peer engines run on the same problems (default none; skipped with
    /// `--no-peers`).
    #[serde(default)]
    pub peers: Vec<Peer>,
}

/// A peer engine declared by a study.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Peer {
    /// Name (a directory name; the charts' legend entry).
    pub name: String,
    /// Program and arguments. An argument that names an existing file
    /// relative to the study file's folder is passed as that file's path.
    pub command: Vec<String>,
}

/// One reference problem and its ladder of settings.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Problem {
    /// Name (a directory name).
    pub name: String,
    /// What the problem tests, for the report (default empty).
    #[serde(default)]
    pub description: String,
    /// Base scene, relative to the study file's folder.
    pub scene: PathBuf,
    /// Where the exact answer comes from.
    pub reference: Reference,
    /// What a rung's resolution `h` is when it declares none (default
    /// `Vertices`).
    #[serde(default)]
    pub resolution: Resolution,
    /// The ladder: one case per rung.
    pub rungs: Vec<Rung>,
    /// Indices of the rungs `--quick` keeps (default: all).
    #[serde(default)]
    pub quick: Option<Vec<usize>>,
    /// Fit a convergence order to the ladder (default true; false for a
    /// ladder whose rungs differ in more than the resolution).
    #[serde(default = "yes")]
    pub fit_order: bool,
    /// Published timings of other codes on this problem, shown in the
    /// table as quoted, not measured, figures (default none).
    #[serde(default)]
    pub quoted: Vec<Quoted>,
}

/// A published timing, quoted in the study's table.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Quoted {
    /// The code, e.g. "Matlab (authors' code)".
    pub engine: String,
    /// The rung it corresponds to.
    pub rung: String,
    /// Vertices.
    pub vertices: usize,
    /// Iterations.
    pub iterations: u64,
    /// Wall time (s).
    pub wall_s: f64,
    /// Where the figure comes from.
    pub source: String,
}

fn yes() -> bool {
    true
}

/// One setting of a problem's ladder.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rung {
    /// Label (a directory name and the row's name in the tables).
    pub label: String,
    /// The resolution the rung stands for, for the convergence fit and for
    /// finding the finest rung (default: the problem's [`Resolution`]).
    #[serde(default)]
    pub h: Option<f64>,
    /// Changes to the scene by dotted path, e.g.
    /// `("membrane.Icosphere.level", 4)` (see `scene_override`).
    #[serde(default)]
    pub set: Vec<(String, serde_json::Value)>,
    /// Threads of the case's run (default 1).
    #[serde(default)]
    pub threads: Option<usize>,
    /// Start from the final state of an earlier rung of the same problem,
    /// refined (default: the scene's own membrane). A continuation: what a
    /// fine mesh needs when it cannot reach the answer from the scene's
    /// start (the 10242-vertex RBC). The case's cost is its own run only.
    #[serde(default)]
    pub start: Option<RungStart>,
}

/// A rung's start from an earlier rung's final state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RungStart {
    /// The earlier rung's label.
    pub rung: String,
    /// Times every triangle is split into four (at most 3), as in
    /// `membrane: State(path, refine: n)`.
    #[serde(default)]
    pub refine: u32,
}

/// The resolution of a case, when its rung declares no `h`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Resolution {
    /// N^(-1/2) for N vertices of the initial mesh: proportional to the
    /// mean edge length over the radius.
    #[default]
    Vertices,
    /// The run's mean time step, simulated time / iterations (s).
    MeanStep,
}

/// The exact answer of a problem.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Reference {
    /// A sphere's bending energy 8πκ (κ of the scene's `Bending` term),
    /// compared with the initial mesh's. A static problem: the cost is the
    /// systems' time per iteration of the case's run.
    SphereBending,
    /// The continuum bending energy of the scene's spheroid
    /// (`membrane: Ellipsoid` with a = b), by 1-D quadrature, compared with
    /// the initial mesh's. Static, as `SphereBending`.
    SpheroidBending,
    /// The continuum minimiser of the bending energy at fixed area and
    /// volume, solved at the reduced volume the case ends at
    /// ([`crate::analysis::axisymmetric`]): E_b/8πκ, D/R0, centre and maximal
    /// thickness over R0, compared with the final mesh. The cost is the
    /// case's whole wall time.
    Axisymmetric,
    /// A quantity at the end of the run, against the same quantity at the
    /// end of the problem's finest finished case (smallest `h`), for
    /// time-step errors. The cost is the case's whole wall time.
    FinestRung(Quantity),
    /// A tube held by named control points on a membrane at constant
    /// tension σ (the scene's `Tension` term): Derényi, Jülicher & Prost
    /// (PRL 88, 238101, 2002), radius r0 = √(κ/2σ) and force
    /// f0 = 2π√(2σκ). Measured over the second half of the run's frames
    /// (medians): the radius of the scene's one `tube_radius` probe and the
    /// force of its named control points (their mean magnitude). The cost
    /// is the case's whole wall time.
    Tether,
    /// A vesicle adhered to the scene's plane `Adhesion` substrate, against
    /// the continuum adhered vesicle of the same area, final reduced volume,
    /// κ and W ([`crate::analysis::axisymmetric::adhered`]): the contact
    /// curvature fitted to the final mesh near the contact line
    /// ([`crate::analysis::axisymmetric::contact_fit`]) against Seifert &
    /// Lipowsky's √(2W/κ), and the height above the bound membrane against
    /// the continuum vesicle's. The cost is the case's whole wall time.
    Adhesion,
}

impl Reference {
    /// Whether the error is measured on the initial mesh (the cost is then
    /// the time per iteration).
    pub fn is_static(self) -> bool {
        matches!(self, Reference::SphereBending | Reference::SpheroidBending)
    }
}

/// A quantity read from a run's summary.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Quantity {
    /// Reduced volume v = 6√π V / A^{3/2}.
    ReducedVolume,
    /// Bending energy (Ē).
    BendingEnergy,
    /// Total energy (Ē).
    TotalEnergy,
    /// Area (l̄²).
    Area,
    /// Volume (l̄³).
    Volume,
}

impl Quantity {
    /// Name in the tables.
    pub fn name(self) -> &'static str {
        match self {
            Quantity::ReducedVolume => "v",
            Quantity::BendingEnergy => "E_b",
            Quantity::TotalEnergy => "E",
            Quantity::Area => "A",
            Quantity::Volume => "V",
        }
    }
}

/// Why a study could not be loaded or run.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// The study file could not be read or parsed, or is invalid.
    #[error("{path}: {reason}")]
    File {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// The output could not be written.
    #[error("{path}: cannot write the study output: {reason}")]
    Output {
        /// The path.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// One case: a problem at one rung.
#[derive(Clone, Debug)]
pub struct Case {
    /// Index of the problem in the study.
    pub problem: usize,
    /// Index of the rung in the problem's ladder.
    pub rung: usize,
    /// The scene with the rung's settings applied.
    pub scene: Scene,
    /// The base scene's path (relative paths in the scene resolve from it).
    pub scene_path: PathBuf,
    /// Run directory, relative to the study's output directory.
    pub dir: PathBuf,
    /// The run directory (relative to the study's) whose final state this
    /// case starts from, and the refinement, if the rung declares a start.
    pub start: Option<(PathBuf, u32)>,
}

/// Whether the run in `dir` stopped on a numerical blow-up and wrote its
/// summary saying so.
fn blew_up(dir: &Path) -> bool {
    crate::io::summary::RunSummary::read(dir)
        .is_ok_and(|s| s.status == crate::io::summary::RunStatus::BlewUp)
}

/// Options of [`run_cases`].
#[derive(Clone, Debug)]
pub struct StudyOptions {
    /// Output directory.
    pub out: PathBuf,
    /// Cases at once (wall times are only comparable with 1).
    pub jobs: usize,
    /// No per-case progress lines.
    pub quiet: bool,
}

/// What [`run_cases`] did.
#[derive(Clone, Debug, Default)]
pub struct StudyRunReport {
    /// Cases in the study (after `--quick`).
    pub cases: usize,
    /// Cases already finished before this call.
    pub skipped: usize,
    /// Cases run now.
    pub completed: usize,
    /// Cases whose run failed, with the error.
    pub failed: Vec<(PathBuf, String)>,
}

/// The file in a case's run directory that records what it was run from.
pub const CASE_FINGERPRINT: &str = "case.json";

/// What a case's result depends on: the scene as run and the threads.
/// A continued case's includes the fingerprint its start rung ran with,
/// so that it runs again when that rung does.
fn fingerprint(study: &Study, case: &Case, out: &Path) -> String {
    let problem = &study.problems[case.problem];
    let rung = &problem.rungs[case.rung];
    let start = rung.start.as_ref().map(|s| {
        let from = out.join(start_dir(&problem.name, s)).join(CASE_FINGERPRINT);
        let theirs = std::fs::read_to_string(from).unwrap_or_default();
        format!("from {} refined {}: {theirs}", s.rung, s.refine)
    });
    let mut f = serde_json::json!({
        "scene": case.scene.to_ron_string().unwrap_or_default(),
        "threads": rung.threads.unwrap_or(1),
        "engine": env!("CARGO_PKG_VERSION"),
    });
    if let Some(start) = start {
        f["start"] = start.into();
    }
    f.to_string()
}

/// The run directory (relative to the study's) of a start's rung.
fn start_dir(problem: &str, start: &RungStart) -> PathBuf {
    Path::new("cases").join(problem).join(&start.rung)
}

/// A case is done when its run directory exists (a run renames it into
/// place when it ends) and was run from exactly this scene; a case whose
/// rung changed runs again.
pub fn is_done(study: &Study, case: &Case, out: &Path) -> bool {
    let dir = out.join(&case.dir);
    dir.join("summary.json").is_file()
        && std::fs::read_to_string(dir.join(CASE_FINGERPRINT))
            .is_ok_and(|f| f == fingerprint(study, case, out))
}

/// The cases `--quick` keeps (all of them without it).
pub fn selected(study: &Study, cases: Vec<Case>, quick: bool) -> Vec<Case> {
    cases
        .into_iter()
        .filter(|c| {
            !quick
                || study.problems[c.problem]
                    .quick
                    .as_ref()
                    .is_none_or(|q| q.contains(&c.rung))
        })
        .collect()
}

/// Runs every case not yet finished, `options.jobs` at a time, each on its
/// own pool of the rung's thread count.
pub fn run_cases(
    study: &Study,
    cases: &[Case],
    options: &StudyOptions,
) -> Result<StudyRunReport, StudyError> {
    std::fs::create_dir_all(&options.out).map_err(|e| StudyError::Output {
        path: options.out.clone(),
        reason: e.to_string(),
    })?;
    let mut report = StudyRunReport {
        cases: cases.len(),
        ..Default::default()
    };
    // A continued case runs after the case it starts from: in waves by
    // the length of its chain of starts, each wave deciding what is done
    // once the one before has run (a start that ran again runs its
    // continuations again).
    let depth = |c: &Case| {
        let rungs = &study.problems[c.problem].rungs;
        let (mut rung, mut d) = (&rungs[c.rung], 0);
        while let Some(start) = &rung.start {
            rung = rungs
                .iter()
                .find(|o| o.label == start.rung)
                .expect("checked when loaded");
            d += 1;
        }
        d
    };
    let deepest = cases.iter().map(depth).max().unwrap_or(0);
    for wave in 0..=deepest {
        let todo: Vec<&Case> = cases
            .iter()
            .filter(|c| depth(c) == wave)
            .filter(|c| {
                let done = is_done(study, c, &options.out);
                report.skipped += usize::from(done);
                !done
            })
            .collect();
        let (completed, failed) = run_wave(study, &todo, options);
        report.completed += completed;
        report.failed.extend(failed);
    }
    Ok(report)
}

/// Runs `todo`, `options.jobs` at a time; returns (completed, failed).
fn run_wave(
    study: &Study,
    todo: &[&Case],
    options: &StudyOptions,
) -> (usize, Vec<(PathBuf, String)>) {
    crate::workflow::job_pool::run_jobs(
        todo.len(),
        options.jobs,
        options.quiet,
        &|| false,
        &|k| todo[k].dir.clone(),
        &|k| {
            study.problems[todo[k].problem].rungs[todo[k].rung]
                .threads
                .unwrap_or(1)
        },
        &|k| {
            let case = todo[k];
            let dir = options.out.join(&case.dir);
            let opts = crate::workflow::run::RunOptions {
                overwrite: true,
                ..crate::workflow::run::RunOptions::quiet(dir.clone())
            };
            let t = std::time::Instant::now();
            let mut scene = case.scene.clone();
            if let Some((from, refine)) = &case.start {
                // Absolute: a scene resolves a relative state path against
                // its own folder, not the working directory `--out` is
                // relative to.
                let path = options.out.join(from).join("state.json");
                scene.membrane = crate::scene::MembraneSource::State {
                    path: std::path::absolute(&path).unwrap_or(path),
                    refine: *refine,
                };
            }
            let mut prepared = crate::workflow::run::prepare_run(&scene, &case.scene_path, &opts)
                .map_err(|e| e.to_string())?;
            let result =
                crate::workflow::run::drive_run(&mut prepared, &case.scene_path, &opts, t, &|| {
                    false
                });
            // A run that blew up still wrote its directory (status
            // `blew_up`): a result like any other, not to be run again.
            // Not fatal: without the fingerprint the case just runs again.
            if dir.join("summary.json").is_file() {
                let _ = crate::atomic_write(
                    &dir.join(CASE_FINGERPRINT),
                    fingerprint(study, case, &options.out).as_bytes(),
                );
            }
            match result {
                Ok(s) => Ok(s.wall_time_s),
                // Kept as a result: the report lists it as `blew_up`.
                Err(_) if blew_up(&dir) => Ok(t.elapsed().as_secs_f64()),
                Err(e) => Err(e.to_string().into()),
            }
        },
    )
}
