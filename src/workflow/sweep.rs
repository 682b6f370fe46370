//! Parameter sweeps: a base scene × conditions × a parameter grid × repeats,
//! expanded into independent runs with distinct derived seeds (SPEC §6, the
//! tether k_d scan of paper Fig 5F).
//!
//! A sweep file (RON) names the base scene (relative to the sweep file),
//! the conditions (each a name, an optional saved state to start from and
//! settings), the grid axes (each a name and a list of settings) and the
//! number of repeats. `remembrane sweep` runs the expansion into
//! `OUT/runs/<condition>/<axis>=<value>…/rep<NN>`, skipping runs whose
//! directory already exists (a run directory appears only when the run has
//! finished), so an interrupted sweep resumes. `--shard I/N` runs only the
//! runs whose index is I mod N, so a batch system (e.g. a Slurm job array)
//! can drive it; `--emit-slurm` prints such a job-array script ([`super::slurm`]).
//!
//! A sweep may declare shared `phases` (a [`crate::workflow::protocol`]): they run
//! once, into `OUT/phases/<phase>/`, before the runs, and a condition can
//! start its runs from one of them (`from_phase`). With phases,
//! `--emit-slurm` prints a campaign script that submits the phases as one
//! job and the run array after it (`--dependency=afterok`).

pub use crate::scene::setting::Setting;
use crate::scene::setting::{ron_options, valid_name};
use crate::scene::{Scene, SceneError};
use crate::util::rng::stream_seed;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Stream id of the derived run seeds.
const SWEEP_SEED_STREAM: u64 = 0x7377_6565_7000_0001;

fn one() -> u32 {
    1
}

/// A sweep file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    /// Name (used in job names).
    pub name: String,
    /// Base scene, relative to the sweep file's folder.
    pub scene: PathBuf,
    /// Repeats of every condition × grid point (default 1).
    #[serde(default = "one")]
    pub repeats: u32,
    /// Base seed from which every run's seed is derived (default 0).
    #[serde(default)]
    pub seed: u64,
    /// Conditions (default: one condition, `base`, with no settings).
    #[serde(default)]
    pub conditions: Vec<Condition>,
    /// Grid axes; runs cover their Cartesian product (default: none).
    #[serde(default)]
    pub grid: Vec<Axis>,
    /// Shared phases run once before the runs (default: none); see
    /// [`Condition::from_phase`].
    #[serde(default)]
    pub phases: Vec<crate::workflow::protocol::Phase>,
}

/// One condition of a sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Condition {
    /// Name (a directory name).
    pub name: String,
    /// Saved state to start from (relative to the sweep file's folder).
    #[serde(default)]
    pub from: Option<PathBuf>,
    /// Start from the final state of this shared phase (one of
    /// [`Sweep::phases`]) instead.
    #[serde(default)]
    pub from_phase: Option<String>,
    /// Settings applied to the base scene.
    #[serde(default)]
    pub set: Vec<Setting>,
}

/// One grid axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    /// Name (used in directory names and the collected tables).
    pub name: String,
    /// The values the axis takes.
    pub values: Vec<Setting>,
}

/// One expanded run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunSpec {
    /// Index in the expansion (shards take index mod N).
    pub index: usize,
    /// Condition name.
    pub condition: String,
    /// (axis name, value label) per grid axis.
    pub point: Vec<(String, String)>,
    /// Numeric value of each grid axis, where it has one.
    pub point_values: Vec<Option<f64>>,
    /// Repeat number (0-based).
    pub repeat: u32,
    /// Derived seed.
    pub seed: u64,
    /// Run directory relative to the sweep's output directory.
    pub dir: PathBuf,
}

/// Why a sweep cannot run.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The sweep file is unreadable or malformed.
    #[error("{}: {reason}", path.display())]
    File {
        /// Sweep file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The base scene is invalid.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A shared phase failed.
    #[error("shared phase `{phase}`: {reason}")]
    Phase {
        /// The phase.
        phase: String,
        /// Its error.
        reason: String,
    },
    /// A run names a condition the sweep does not declare.
    #[error("unknown condition `{0}`")]
    UnknownCondition(String),
    /// A run names a value a grid axis does not have.
    #[error("axis `{axis}` has no value {label}")]
    UnknownValue {
        /// The axis.
        axis: String,
        /// The value's label.
        label: String,
    },
    /// A setting does not fit the scene.
    #[error(transparent)]
    Setting(#[from] crate::scene::setting::SettingError),
}

/// A `--shard I/N` argument that is not one.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// Not of the form `I/N`.
    #[error("--shard must be I/N, e.g. 0/4 (got `{0}`)")]
    Form(String),
    /// `I` or `N` is not a number.
    #[error("--shard: `{0}` is not a number")]
    NotANumber(String),
    /// Not 0 ≤ I < N.
    #[error("--shard I/N needs 0 ≤ I < N (got {i}/{n})")]
    OutOfRange {
        /// The shard.
        i: usize,
        /// The shard count.
        n: usize,
    },
}

/// A protocol-checking error as a sweep error.
fn phase_error(e: crate::workflow::protocol::ProtocolError) -> SweepError {
    use crate::workflow::protocol::ProtocolError;
    match e {
        ProtocolError::Scene(s) => SweepError::Scene(s),
        ProtocolError::File { path, reason } | ProtocolError::Io { path, reason } => {
            SweepError::File { path, reason }
        }
        other => SweepError::Phase {
            phase: String::new(),
            reason: other.to_string(),
        },
    }
}

impl Sweep {
    /// Reads and checks a sweep file: it parses, the base scene loads, every
    /// condition's and grid value's settings apply to it, names are unique,
    /// and every `from` state exists.
    pub fn load(path: &Path) -> Result<(Self, Scene), SweepError> {
        let (sweep, scene) = Self::parse(path)?;
        for (i, c) in sweep.conditions.iter().enumerate() {
            if let Some(from) = &c.from {
                let p = sweep.relative(path, from);
                if !p.is_file() {
                    return Err(SweepError::File {
                        path: path.to_owned(),
                        reason: format!(
                            "field `conditions[{i}].from`: no state file at {} (run the earlier phase first)",
                            p.display()
                        ),
                    });
                }
            }
        }
        Ok((sweep, scene))
    }

    /// [`Sweep::load`] without checking that the `from` states exist yet.
    pub fn parse(path: &Path) -> Result<(Self, Scene), SweepError> {
        let err = |reason: String| SweepError::File {
            path: path.to_owned(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(format!("cannot read: {e}")))?;
        let sweep: Sweep = ron_options().from_str(&text).map_err(|e| {
            err(format!(
                "{}:{}: {}",
                e.span.start.line, e.span.start.col, e.code
            ))
        })?;
        let scene_path = sweep.scene_path(path);
        let scene = Scene::load(&scene_path)?;
        scene
            .refuse_ladder("a sweep's job")
            .map_err(|r| err(format!("field `scene` ({}): {r}", scene_path.display())))?;
        if sweep.repeats == 0 {
            return Err(err("field `repeats`: must be at least 1".into()));
        }
        for (i, c) in sweep.conditions.iter().enumerate() {
            if sweep.conditions[..i].iter().any(|o| o.name == c.name) {
                return Err(err(format!(
                    "field `conditions[{i}].name`: `{}` is used twice",
                    c.name
                )));
            }
            if !valid_name(&c.name) {
                return Err(err(format!(
                    "field `conditions[{i}].name`: `{}` must be a plain directory name",
                    c.name
                )));
            }
            if let Some(phase) = &c.from_phase {
                if c.from.is_some() {
                    return Err(err(format!(
                        "field `conditions[{i}]`: give `from` or `from_phase`, not both"
                    )));
                }
                if !sweep.phases.iter().any(|p| &p.name == phase) {
                    let names: Vec<&str> = sweep.phases.iter().map(|p| p.name.as_str()).collect();
                    return Err(err(format!(
                        "field `conditions[{i}].from_phase`: no shared phase `{phase}` (phases: {})",
                        if names.is_empty() {
                            "none".to_string()
                        } else {
                            names.join(", ")
                        }
                    )));
                }
            }
            let mut s = scene.clone();
            for (k, setting) in c.set.iter().enumerate() {
                setting
                    .apply(&mut s)
                    .map_err(|r| err(format!("field `conditions[{i}].set[{k}]`: {r}")))?;
            }
        }
        for (a, axis) in sweep.grid.iter().enumerate() {
            if axis.values.is_empty() {
                return Err(err(format!("field `grid[{a}].values`: empty")));
            }
            if !valid_name(&axis.name) {
                return Err(err(format!(
                    "field `grid[{a}].name`: `{}` must be a plain name",
                    axis.name
                )));
            }
            for (k, v) in axis.values.iter().enumerate() {
                v.apply(&mut scene.clone())
                    .map_err(|r| err(format!("field `grid[{a}].values[{k}]`: {r}")))?;
            }
        }
        crate::workflow::protocol::check_phases(&sweep.phases, path, "phases")
            .map_err(phase_error)?;
        Ok((sweep, scene))
    }

    fn relative(&self, sweep_path: &Path, p: &Path) -> PathBuf {
        sweep_path.parent().unwrap_or(Path::new(".")).join(p)
    }

    /// The base scene's path.
    pub fn scene_path(&self, sweep_path: &Path) -> PathBuf {
        self.relative(sweep_path, &self.scene)
    }

    /// The conditions (one `base` condition if none are declared).
    pub fn conditions(&self) -> Vec<Condition> {
        if self.conditions.is_empty() {
            vec![Condition {
                name: "base".into(),
                from: None,
                from_phase: None,
                set: Vec::new(),
            }]
        } else {
            self.conditions.clone()
        }
    }

    /// Every run, in a fixed order (condition, grid point, repeat).
    pub fn expand(&self) -> Vec<RunSpec> {
        let mut points: Vec<Vec<usize>> = vec![Vec::new()];
        for axis in &self.grid {
            points = points
                .into_iter()
                .flat_map(|p| {
                    (0..axis.values.len()).map(move |k| {
                        let mut q = p.clone();
                        q.push(k);
                        q
                    })
                })
                .collect();
        }
        let mut runs = Vec::new();
        for c in self.conditions() {
            for p in &points {
                let point: Vec<(String, String)> = p
                    .iter()
                    .zip(&self.grid)
                    .map(|(&k, a)| (a.name.clone(), a.values[k].label()))
                    .collect();
                let point_values: Vec<Option<f64>> = p
                    .iter()
                    .zip(&self.grid)
                    .map(|(&k, a)| a.values[k].value())
                    .collect();
                for repeat in 0..self.repeats {
                    let index = runs.len();
                    let mut dir = PathBuf::from("runs").join(&c.name);
                    let label: Vec<String> =
                        point.iter().map(|(a, v)| format!("{a}={v}")).collect();
                    if !label.is_empty() {
                        dir.push(label.join("_"));
                    }
                    dir.push(format!("rep{repeat:02}"));
                    runs.push(RunSpec {
                        index,
                        condition: c.name.clone(),
                        point: point.clone(),
                        point_values: point_values.clone(),
                        repeat,
                        seed: stream_seed(self.seed, SWEEP_SEED_STREAM, index as u64),
                        dir,
                    });
                }
            }
        }
        runs
    }

    /// The scene and start state of `run` (shared phases in
    /// `out/phases/`).
    pub fn scene_for(
        &self,
        sweep_path: &Path,
        out: &Path,
        base: &Scene,
        run: &RunSpec,
    ) -> Result<(Scene, Option<PathBuf>), SweepError> {
        let mut scene = base.clone();
        let conditions = self.conditions();
        let c = conditions
            .iter()
            .find(|c| c.name == run.condition)
            .ok_or_else(|| SweepError::UnknownCondition(run.condition.clone()))?;
        for s in &c.set {
            s.apply(&mut scene)?;
        }
        for (axis, (_, label)) in self.grid.iter().zip(&run.point) {
            let value = axis
                .values
                .iter()
                .find(|v| &v.label() == label)
                .ok_or_else(|| SweepError::UnknownValue {
                    axis: axis.name.clone(),
                    label: label.clone(),
                })?;
            value.apply(&mut scene)?;
        }
        scene.seed = run.seed;
        let from = match (&c.from, &c.from_phase) {
            (Some(f), _) => Some(self.relative(sweep_path, f)),
            (None, Some(phase)) => Some(phases_dir(out).join(phase).join("state.json")),
            (None, None) => None,
        };
        Ok((scene, from))
    }
}

/// Where a sweep's shared phases are written.
pub fn phases_dir(out: &Path) -> PathBuf {
    out.join("phases")
}

/// Parses `I/N` (0 ≤ I < N).
pub fn parse_shard(s: &str) -> Result<(usize, usize), ShardError> {
    let (i, n) = s
        .split_once('/')
        .ok_or_else(|| ShardError::Form(s.to_string()))?;
    let i: usize = i
        .trim()
        .parse()
        .map_err(|_| ShardError::NotANumber(i.to_string()))?;
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| ShardError::NotANumber(n.to_string()))?;
    if n == 0 || i >= n {
        return Err(ShardError::OutOfRange { i, n });
    }
    Ok((i, n))
}

/// What `run_sweep` did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SweepReport {
    /// Runs in the whole expansion.
    pub total: usize,
    /// Runs in this shard.
    pub in_shard: usize,
    /// Runs skipped because they had finished before.
    pub skipped: usize,
    /// Runs completed now.
    pub completed: usize,
    /// Runs that failed now: (run directory, error).
    pub failed: Vec<(PathBuf, String)>,
    /// The shared phases (run now or kept from before).
    pub phases: Vec<crate::workflow::protocol::PhaseRecord>,
}

/// The expansion written to `OUT/sweep.json` (what `collect` reads).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepIndex {
    /// The sweep's name.
    pub name: String,
    /// The sweep file.
    pub sweep_file: PathBuf,
    /// Grid axis names.
    pub axes: Vec<String>,
    /// Every run.
    pub runs: Vec<RunSpec>,
}

/// Options of [`run_sweep`].
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// Output directory.
    pub out: PathBuf,
    /// Runs at once on this machine (each single-threaded).
    pub jobs: usize,
    /// (I, N): run only the runs with index ≡ I (mod N).
    pub shard: Option<(usize, usize)>,
    /// Override every run's iterations (quick sweeps, tests).
    pub iterations: Option<u64>,
    /// No per-run progress lines.
    pub quiet: bool,
    /// Run only the shared phases (the first job of a Slurm campaign).
    pub phases_only: bool,
}

/// Runs the sweep's share of runs (see the module docs).
pub fn run_sweep(sweep_path: &Path, options: &SweepOptions) -> Result<SweepReport, SweepError> {
    run_sweep_with(sweep_path, options, &|| false)
}

/// Runs the sweep's phases (a whole sweep, or the phases job of a
/// campaign), or, in a shard of a campaign, checks that the phases its
/// conditions start from have run.
fn sweep_phases(
    sweep: &Sweep,
    sweep_path: &Path,
    options: &SweepOptions,
) -> Result<Vec<crate::workflow::protocol::PhaseRecord>, SweepError> {
    let out = &options.out;
    if !sweep.phases.is_empty() {
        let dir = phases_dir(out);
        if options.phases_only || options.shard.is_none() {
            let scenes =
                crate::workflow::protocol::check_phases(&sweep.phases, sweep_path, "phases")
                    .map_err(phase_error)?;
            let phase_options = crate::workflow::protocol::PhaseRunOptions {
                progress: if options.quiet {
                    crate::workflow::run::Progress::Quiet
                } else {
                    crate::workflow::run::Progress::Lines
                },
                iterations: options.iterations,
                frames: None,
                check_invariants: None,
                skip_completed: true,
                checkpoint_every: None,
                resume: false,
            };
            let base_dir = sweep_path.parent().unwrap_or(Path::new("."));
            return crate::workflow::protocol::run_phases(
                &sweep.phases,
                &scenes,
                base_dir,
                &dir,
                &phase_options,
            )
            .map_err(|f| SweepError::Phase {
                phase: sweep.phases[f.index].name.clone(),
                reason: f.error.to_string(),
            });
        } else {
            // A shard of a campaign: the phases job has run them.
            for c in sweep.conditions() {
                if let Some(phase) = &c.from_phase
                    && !dir.join(phase).join("state.json").is_file()
                {
                    return Err(SweepError::Phase {
                        phase: phase.clone(),
                        reason: format!(
                            "has not run (no {}): run `remembrane sweep {} --out {} --phases-only` first \
                             (the campaign that --emit-slurm prints does)",
                            dir.join(phase).join("state.json").display(),
                            sweep_path.display(),
                            out.display()
                        ),
                    });
                }
            }
        }
    }
    Ok(Vec::new())
}

/// [`run_sweep`], stopped when `cancel` returns true (Ctrl-C in the Python
/// package): no new run starts, and the runs in progress stop as
/// interrupted runs do (their directories stay `.incomplete`).
pub fn run_sweep_with(
    sweep_path: &Path,
    options: &SweepOptions,
    cancel: &(dyn Fn() -> bool + Sync),
) -> Result<SweepReport, SweepError> {
    let (sweep, base) = Sweep::load(sweep_path)?;
    let runs = sweep.expand();
    let out = &options.out;
    let io = |e: std::io::Error| SweepError::File {
        path: out.clone(),
        reason: format!("cannot write the sweep output: {e}"),
    };
    std::fs::create_dir_all(out).map_err(io)?;
    let index = SweepIndex {
        name: sweep.name.clone(),
        sweep_file: std::path::absolute(sweep_path).unwrap_or_else(|_| sweep_path.to_owned()),
        axes: sweep.grid.iter().map(|a| a.name.clone()).collect(),
        runs: runs.clone(),
    };
    // Every shard writes the same index; the write is atomic.
    let json = serde_json::to_string_pretty(&index).expect("the index serialises");
    crate::atomic_write(&out.join("sweep.json"), json.as_bytes()).map_err(io)?;
    let phase_records = sweep_phases(&sweep, sweep_path, options)?;
    if options.phases_only {
        return Ok(SweepReport {
            total: runs.len(),
            phases: phase_records,
            ..Default::default()
        });
    }
    let mine: Vec<&RunSpec> = runs
        .iter()
        .filter(|r| options.shard.is_none_or(|(i, n)| r.index % n == i))
        .collect();
    let mut report = SweepReport {
        total: runs.len(),
        in_shard: mine.len(),
        phases: phase_records,
        ..Default::default()
    };
    let todo: Vec<&RunSpec> = mine
        .into_iter()
        .filter(|r| {
            let done = out.join(&r.dir).join("summary.json").is_file();
            report.skipped += usize::from(done);
            !done
        })
        .collect();
    let scene_path = sweep.scene_path(sweep_path);
    // One thread per run: runs are independent, results do not depend on
    // the thread count.
    let results = crate::workflow::job_pool::run_jobs(
        todo.len(),
        options.jobs,
        options.quiet,
        cancel,
        &|k| todo[k].dir.clone(),
        &|_| 1,
        &|k| {
            let run = todo[k];
            let (scene, from) = sweep
                .scene_for(sweep_path, out, &base, run)
                .map_err(|e| e.to_string())?;
            let opts = crate::workflow::run::RunOptions {
                overwrite: true,
                iterations: options.iterations,
                from,
                ..crate::workflow::run::RunOptions::quiet(out.join(&run.dir))
            };
            let started = std::time::Instant::now();
            let mut prepared = crate::workflow::run::prepare_run(&scene, &scene_path, &opts)
                .map_err(|e| e.to_string())?;
            crate::workflow::run::drive_run(&mut prepared, &scene_path, &opts, started, cancel)
                .map(|s| s.wall_time_s)
                .map_err(|e| e.to_string().into())
        },
    );
    (report.completed, report.failed) = results;
    Ok(report)
}
