//! Running a scene to completion with outputs: the driver behind
//! `remembrane run`.

use crate::engine::shared_resources::AbnormalEdges;
use crate::engine::simulation::{
    BuildError, CheckInvariants, DenseLipid, DensePositions, InitialState, SimBuilder, SimError,
    Simulation,
};
use crate::io::checkpoint::{Checkpoint, CheckpointError};
use crate::io::output::{FrameSchedule, OpenOutput, OutputError, RunOutput};
use crate::io::report::EnergyReport;
use crate::io::summary::{MinimiserSummary, RemeshSummary, RunStatus, RunSummary};
use crate::remesh::RemeshStats;
use crate::scene::{Scene, SceneError};
use std::path::{Path, PathBuf};
use std::time::Instant;

mod summarize;

pub use summarize::*;

/// How a run reports progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// A progress bar with iterations/s and ETA (terminals).
    Bar,
    /// A plain line every 10 % (logs, pipes).
    Lines,
    /// Nothing.
    Quiet,
}

impl Progress {
    /// Nothing when `quiet`, else a bar on a terminal and lines otherwise.
    pub fn for_stderr(quiet: bool) -> Self {
        use std::io::IsTerminal;
        if quiet {
            Progress::Quiet
        } else if std::io::stderr().is_terminal() {
            Progress::Bar
        } else {
            Progress::Lines
        }
    }
}

/// Options of a run; `None` keeps the scene's value.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Output directory.
    pub out: PathBuf,
    /// Replace an existing output directory.
    pub overwrite: bool,
    /// Override the scene's seed.
    pub seed: Option<u64>,
    /// Override the number of iterations.
    pub iterations: Option<u64>,
    /// Override the number of frames.
    pub frames: Option<u32>,
    /// Start from this saved state (`state.json` of an earlier run) instead
    /// of the scene's membrane.
    pub from: Option<PathBuf>,
    /// Progress reporting.
    pub progress: Progress,
    /// Check every mesh invariant after each topology edit (slow): `None`
    /// keeps the build's default (on in debug builds, off in release),
    /// `Some(on)` overrides it.
    pub check_invariants: Option<bool>,
    /// Write a checkpoint every so many iterations (`--checkpoint-every`).
    pub checkpoint: Option<CheckpointSettings>,
}

impl RunOptions {
    /// A run into `out` with the scene's own settings, no progress output,
    /// no invariant checks and no checkpoints: write the fields that differ
    /// as `RunOptions { iterations: Some(n), ..RunOptions::quiet(out) }`.
    pub fn quiet(out: impl Into<PathBuf>) -> Self {
        Self {
            out: out.into(),
            overwrite: false,
            seed: None,
            iterations: None,
            frames: None,
            from: None,
            progress: Progress::Quiet,
            check_invariants: None,
            checkpoint: None,
        }
    }
}

/// Checkpointing of a run (see [`crate::io::checkpoint`]).
#[derive(Clone, Debug, PartialEq)]
pub struct CheckpointSettings {
    /// Iterations between checkpoints (at least 1).
    pub every: u64,
    /// The scene file's text, kept in the checkpoint so that a resumed run
    /// rebuilds exactly the scene that was started.
    pub scene_text: String,
}

/// A run that could not start or finish.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The scene is invalid.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// Outputs could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The simulation stopped; the outputs up to then are in `dir`.
    #[error("{source} (outputs up to the last good frame are in {})", dir.display())]
    Stopped {
        /// The simulation error.
        source: SimError,
        /// The run directory.
        dir: PathBuf,
    },
    /// The simulation could not start (e.g. an invalid schedule).
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A checkpoint could not be read or does not fit its scene.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// The run was interrupted (Ctrl-C); its outputs so far stay in the
    /// staging directory, which does not look like a result.
    #[error("interrupted at iteration {iteration}; partial outputs are in {}", staging.display())]
    Interrupted {
        /// Iterations done.
        iteration: u64,
        /// The `DIR.incomplete` staging directory.
        staging: PathBuf,
    },
}

impl From<crate::mesh::topology::TopologyError> for RunError {
    fn from(e: crate::mesh::topology::TopologyError) -> Self {
        RunError::Sim(SimError::Topology(e))
    }
}

impl RunError {
    /// Exit code: 2 for bad input, 1 for a run that failed.
    pub fn exit_code(&self) -> u8 {
        match self {
            RunError::Scene(_) | RunError::Checkpoint(_) => 2,
            RunError::Output(OutputError::Exists(_)) => 2,
            _ => 1,
        }
    }
}

/// Builds `scene` (from `scene_path`) and runs it with `options`, writing all
/// outputs. `customize` may add plugins, systems and force terms to the
/// builder before the simulation is sealed.
pub fn run_scene(
    scene: &Scene,
    scene_path: &Path,
    options: &RunOptions,
    customize: impl FnOnce(&mut SimBuilder) -> Result<(), BuildError>,
) -> Result<RunSummary, RunError> {
    let started = Instant::now();
    let mut pending = PendingRun::new(scene, scene_path, options)?;
    customize(&mut pending.builder).map_err(|e| SceneError::Invalid {
        path: scene_path.to_owned(),
        field: "systems".into(),
        reason: e.to_string(),
    })?;
    let mut run = pending.build(scene_path)?;
    drive_run(&mut run, scene_path, options, started, &|| false)
}

/// A scene with the run's overrides applied and its builder holding every
/// plugin the scene declares, not yet sealed: a caller may add its own
/// plugins and force terms before [`PendingRun::build`].
pub struct PendingRun {
    /// The scene as run (seed, iterations, frames and `from` applied).
    pub scene: Scene,
    /// The run's name (the scene's, else the file stem).
    pub name: String,
    /// The builder.
    pub builder: SimBuilder,
}

impl PendingRun {
    /// Applies `options`' overrides (seed, iterations, frames, start state,
    /// invariant checks) to `scene` and assembles its builder.
    pub fn new(scene: &Scene, scene_path: &Path, options: &RunOptions) -> Result<Self, RunError> {
        let mut scene = scene.clone();
        if let Some(seed) = options.seed {
            scene.seed = seed;
        }
        if let Some(n) = options.iterations {
            scene.dynamics.iterations = n;
        }
        if let Some(f) = options.frames {
            scene.dynamics.frames = f;
        }
        if let Some(from) = &options.from {
            // Absolute, so it does not depend on the scene file's folder.
            let path = std::path::absolute(from).unwrap_or_else(|_| from.clone());
            scene.membrane = crate::scene::MembraneSource::State { path, refine: 0 };
        }
        let name = run_name(&scene, scene_path);
        let mut builder = scene.builder(scene_path)?;
        if let Some(c) = builder.resource_mut::<CheckInvariants>() {
            c.0 = options.check_invariants.unwrap_or(c.0);
        }
        Ok(Self {
            scene,
            name,
            builder,
        })
    }

    /// Seals the simulation; a schedule that cannot run is an error of the
    /// scene's `systems`.
    pub fn build(self, scene_path: &Path) -> Result<PreparedRun, RunError> {
        let sim = self.builder.build().map_err(|e| SceneError::Invalid {
            path: scene_path.to_owned(),
            field: "systems".into(),
            reason: e.to_string(),
        })?;
        if let Some(name) = sim
            .summary_section_names()
            .into_iter()
            .find(|n| crate::io::summary::SUMMARY_FIELDS.contains(&n.as_str()))
        {
            return Err(SceneError::Invalid {
                path: scene_path.to_owned(),
                field: "systems".into(),
                reason: format!(
                    "a plugin's summary section is named `{name}`, a field summary.json has already"
                ),
            }
            .into());
        }
        Ok(PreparedRun {
            scene: self.scene,
            name: self.name,
            sim,
            resume: None,
        })
    }
}

/// A scene with the run's overrides applied and its simulation built and
/// sealed, before its first tick: what [`drive_run`] runs.
pub struct PreparedRun {
    /// The scene as run (seed, iterations, frames and `from` applied).
    pub scene: Scene,
    /// The run's name (the scene's, else the file stem).
    pub name: String,
    /// The simulation.
    pub sim: Simulation,
    /// The checkpoint this run continues from ([`resume_run`]), if any.
    pub resume: Option<Box<Checkpoint>>,
}

/// The scene's name, or the file stem of `scene_path` when it has none.
pub fn run_name(scene: &Scene, scene_path: &Path) -> String {
    if scene.name.is_empty() {
        scene_path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    } else {
        scene.name.clone()
    }
}

/// Applies `options`' overrides (seed, iterations, frames, start state) to
/// `scene` and builds its simulation ([`PendingRun`], sealed at once).
pub fn prepare_run(
    scene: &Scene,
    scene_path: &Path,
    options: &RunOptions,
) -> Result<PreparedRun, RunError> {
    PendingRun::new(scene, scene_path, options)?.build(scene_path)
}

/// Continues the run whose output directory is `dir` from the checkpoint
/// in its staging directory (`dir.incomplete/checkpoint.json`): rebuilds
/// its scene from the saved text and overrides, restores the saved state
/// and runs to the end, writing exactly what the uninterrupted run would
/// have written. `every` replaces the checkpoint interval.
pub fn resume_run(
    dir: &Path,
    progress: Progress,
    every: Option<u64>,
) -> Result<RunSummary, RunError> {
    let started = Instant::now();
    let mut resumed = prepare_resume(dir, progress, every)?;
    drive_run(
        &mut resumed.run,
        &resumed.scene_path,
        &resumed.options,
        started,
        &|| false,
    )
}

/// A run rebuilt from its checkpoint, not yet restored or started
/// ([`drive_run`] restores the checkpoint in `run.resume`).
pub struct ResumedRun {
    /// The rebuilt run, with the checkpoint in `resume`.
    pub run: PreparedRun,
    /// Its options, as the run was started (the interval may differ).
    pub options: RunOptions,
    /// The scene file as the run was given it.
    pub scene_path: PathBuf,
}

/// Reads the checkpoint of the run in `dir` and rebuilds its scene with the
/// run's overrides; checks that the scene's membrane starts as it did.
pub fn prepare_resume(
    dir: &Path,
    progress: Progress,
    every: Option<u64>,
) -> Result<ResumedRun, RunError> {
    let checkpoint = Checkpoint::read(dir)?;
    let source = &checkpoint.run;
    // Relative paths inside the scene resolve against the scene file.
    let load_path = source.working_dir.join(&source.scene_path);
    let scene = Scene::from_ron_str(&source.scene_text, &load_path)?;
    let options = RunOptions {
        out: crate::io::checkpoint::run_dir_of(dir),
        overwrite: false,
        seed: source.seed,
        iterations: source.iterations,
        frames: source.frames,
        from: source.from.clone(),
        progress,
        check_invariants: source.check_invariants,
        checkpoint: Some(CheckpointSettings {
            every: every.unwrap_or(source.every),
            scene_text: source.scene_text.clone(),
        }),
    };
    let mut run = prepare_run(&scene, &load_path, &options)?;
    let initial = *run.sim.resource::<InitialState>();
    if initial != checkpoint.initial {
        return Err(RunError::Checkpoint(CheckpointError {
            path: crate::io::checkpoint::staging_of(dir)
                .join(crate::io::checkpoint::CHECKPOINT_FILE),
            reason: format!(
                "the scene's membrane now starts with {} vertices, area {} and volume {}, the checkpointed run with {}, {} and {}: a mesh or state file it reads has changed",
                initial.vertices,
                initial.area,
                initial.volume,
                checkpoint.initial.vertices,
                checkpoint.initial.area,
                checkpoint.initial.volume
            ),
        }));
    }
    let scene_path = source.scene_path.clone();
    run.resume = Some(Box::new(checkpoint));
    Ok(ResumedRun {
        run,
        options,
        scene_path,
    })
}

/// Runs a prepared, not yet started simulation to the end of its scene
/// (iterations or duration), writing every output into `options.out`.
/// `started` is when the run's wall time began. `interrupted` is asked
/// after every tick; when it returns true the run stops with
/// [`RunError::Interrupted`] and its staging directory stays
/// `DIR.incomplete`, as for a killed process.
pub fn drive_run(
    run: &mut PreparedRun,
    scene_path: &Path,
    options: &RunOptions,
    started: Instant,
    interrupted: &dyn Fn() -> bool,
) -> Result<RunSummary, RunError> {
    let PreparedRun {
        scene,
        name,
        sim,
        resume,
    } = run;
    let resume = resume.take();
    let name = name.as_str();
    let iterations = scene.dynamics.iterations;
    let duration = scene.dynamics.duration.unwrap_or(f64::INFINITY);
    *sim.resource_mut::<FrameSchedule>() = FrameSchedule::new(
        iterations,
        scene.dynamics.frames,
        scene.dynamics.frame_time,
        duration,
    );
    let earlier_wall = resume.as_ref().map_or(0.0, |c| c.wall_time_s);
    open_output(sim, options, resume.as_deref())?;
    let source = checkpoint_source(scene_path, options, resume.as_deref());
    let write_checkpoint = |sim: &Simulation, source| -> Result<(), RunError> {
        let wall = earlier_wall + started.elapsed().as_secs_f64();
        let checkpoint = Checkpoint::capture(sim, source, wall)?;
        Ok(sim
            .resource::<OpenOutput>()
            .get()
            .expect("the run's output is open")
            .write_checkpoint(&checkpoint.to_json())?)
    };
    // A first checkpoint before the first tick: a scene whose state cannot
    // be saved (a plugin's own entities) fails here, not hours later.
    if let Some(source) = &source
        && resume.is_none()
        && let Err(e) = write_checkpoint(sim, source)
    {
        take_output(sim).discard();
        return Err(e);
    }
    let stop = tick_to_the_end(
        sim,
        name,
        (iterations, duration),
        options.progress,
        started,
        interrupted,
        |sim, it| match &source {
            Some(source)
                if it.is_multiple_of(source.every)
                    && it < iterations
                    && sim.clock().time < duration =>
            {
                write_checkpoint(sim, source)
            }
            _ => Ok(()),
        },
    )?;
    let wall = || earlier_wall + started.elapsed().as_secs_f64();
    finish_run(sim, name, scene, scene_path, stop, wall)
}

/// Opens the run's output: a new staging directory, or for a resumed run
/// the one its checkpoint left, whose state it then restores. A failed
/// restore leaves the staging directory and its checkpoint as they were.
fn open_output(
    sim: &mut Simulation,
    options: &RunOptions,
    resume: Option<&Checkpoint>,
) -> Result<(), RunError> {
    let out = match resume {
        None => RunOutput::create(&options.out, options.overwrite)?,
        Some(checkpoint) => RunOutput::reopen(&options.out, &checkpoint.output)?,
    };
    sim.resource_mut::<OpenOutput>().0 = Some(out);
    if let Some(checkpoint) = resume {
        checkpoint.restore_into(sim).map_err(|e| {
            RunError::Checkpoint(CheckpointError {
                path: crate::io::checkpoint::staging_of(&options.out)
                    .join(crate::io::checkpoint::CHECKPOINT_FILE),
                reason: e.to_string(),
            })
        })?;
    }
    Ok(())
}

/// Takes the run's output directory back from the simulation.
fn take_output(sim: &mut Simulation) -> RunOutput {
    sim.resource_mut::<OpenOutput>()
        .0
        .take()
        .expect("the run's output is open until the run ends")
}

/// What a checkpoint records of how the run was started (`None` without
/// checkpoints).
fn checkpoint_source(
    scene_path: &Path,
    options: &RunOptions,
    resume: Option<&Checkpoint>,
) -> Option<crate::io::checkpoint::RunSource> {
    options
        .checkpoint
        .as_ref()
        .map(|c| crate::io::checkpoint::RunSource {
            scene_path: scene_path.to_owned(),
            // A resumed run keeps the directory the run started in, which
            // its relative scene path is resolved against.
            working_dir: resume.as_ref().map_or_else(
                || std::env::current_dir().unwrap_or_default(),
                |c| c.run.working_dir.clone(),
            ),
            scene_text: c.scene_text.clone(),
            seed: options.seed,
            iterations: options.iterations,
            frames: options.frames,
            from: options
                .from
                .as_ref()
                .map(|f| std::path::absolute(f).unwrap_or_else(|_| f.clone())),
            check_invariants: options.check_invariants,
            every: c.every.max(1),
        })
}

/// Ticks until the scene's iterations or duration are reached, a tick
/// fails (returned as the stop) or a stop is requested, reporting progress
/// and calling `after_tick` with each iteration reached (checkpoints). An
/// interrupt ends the run with [`RunError::Interrupted`].
fn tick_to_the_end(
    sim: &mut Simulation,
    name: &str,
    (iterations, duration): (u64, f64),
    progress: Progress,
    started: Instant,
    interrupted: &dyn Fn() -> bool,
    mut after_tick: impl FnMut(&Simulation, u64) -> Result<(), RunError>,
) -> Result<Option<SimError>, RunError> {
    let bar = progress_bar(progress, iterations);
    let mut stop: Option<SimError> = None;
    // Lines every 10 % of the run, from where it starts (a resumed run
    // starts at its checkpoint).
    let tenth = (iterations / 10).max(1);
    let mut next_line = (sim.clock().iteration / tenth + 1) * tenth;
    if let Some(b) = &bar {
        b.set_position(sim.clock().iteration);
    }
    while sim.clock().iteration < iterations && sim.clock().time < duration {
        // Each tick's Observe stage writes the frame of the state before it
        // (with the forces the step applies) when one is due.
        let ticked = sim.tick();
        let it = sim.clock().iteration;
        // An interrupt can surface as a failed tick (e.g. Ctrl-C inside a
        // Python force term): it is an interrupt, not a blow-up.
        if interrupted() {
            if let Some(b) = &bar {
                b.abandon();
            }
            let out = take_output(sim);
            return Err(RunError::Interrupted {
                iteration: it,
                staging: out.staging().to_owned(),
            });
        }
        if let Err(e) = ticked {
            stop = Some(e);
            break;
        }
        if sim
            .resource::<crate::engine::simulation::StopRequest>()
            .0
            .is_some()
        {
            break;
        }
        after_tick(sim, it)?;
        if let Some(b) = &bar {
            b.set_position(it);
        } else if progress == Progress::Lines && it >= next_line && iterations >= 10 {
            eprintln!(
                "{name}: iteration {it}/{iterations} ({:.0} s)",
                started.elapsed().as_secs_f64()
            );
            next_line += tenth;
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    Ok(stop)
}

/// The final state's forces and frame, then the summary, events, state
/// and mesh written and the staging directory renamed into place.
fn finish_run(
    sim: &mut Simulation,
    name: &str,
    scene: &Scene,
    scene_path: &Path,
    mut stop: Option<SimError>,
    wall: impl Fn() -> f64,
) -> Result<RunSummary, RunError> {
    // Final state: its forces and its frame.
    if stop.is_none() {
        if let Err(e) = sim.observe() {
            stop = Some(e);
            regather(sim)?;
        }
    } else {
        // Positions in the world are the last good ones (integration checks
        // before writing back); re-gather without the failing forces.
        regather(sim)?;
    }
    let out = take_output(sim);
    let summary = summarize(name, scene, scene_path, sim, &out, stop.as_ref(), wall());
    let json =
        serde_json::to_string_pretty(&summary).map_err(|e| SimError::Output(e.to_string()))?;
    release_tick_scratch(sim);
    let mesh = sim.membrane_mut().to_mesh()?;
    let lipid = sim.resource::<DenseLipid>().0.clone();
    if let Ok(stats) = sim.resources().get::<RemeshStats>() {
        out.write_events(&stats.events)?;
    }
    // Only a completed run leaves a state to continue from.
    let clock = sim.clock();
    let state = stop.is_none().then(|| {
        crate::io::state::SavedState::new(
            name,
            scene.seed,
            clock.iteration,
            clock.time,
            &mesh,
            &lipid,
        )
        .to_json()
    });
    let fields = species_fields(sim, &mesh);
    let dir = out.finish(&json, &mesh, &lipid, &fields, state.as_deref())?;
    match stop {
        None => Ok(summary),
        Some(source) => Err(RunError::Stopped { source, dir }),
    }
}

/// The protein species' area fractions on the final mesh, as `phi_<name>`
/// (none without species).
fn species_fields(sim: &Simulation, mesh: &crate::mesh::SurfaceMesh) -> Vec<(String, Vec<f64>)> {
    use crate::species::model::SpeciesModel;
    use crate::species::state::{SpeciesAmounts, fractions_at};
    let Ok(model) = sim.resources().get::<SpeciesModel>() else {
        return Vec::new();
    };
    let membrane = sim.membrane();
    let mut amounts = SpeciesAmounts::default();
    let set = &model.set;
    amounts.gather(
        &membrane.world,
        membrane.cached_topology(),
        set.species.len(),
    );
    let phi = fractions_at(
        set,
        &amounts.0,
        &mesh.positions,
        &mesh.faces,
        model.base.discretisation,
    );
    set.species
        .iter()
        .zip(phi)
        .map(|(s, p)| (format!("phi_{}", s.name), p))
        .collect()
}

fn progress_bar(progress: Progress, iterations: u64) -> Option<indicatif::ProgressBar> {
    if progress != Progress::Bar {
        return None;
    }
    let bar = indicatif::ProgressBar::new(iterations);
    let style = indicatif::ProgressStyle::with_template(
        "{bar:40} {pos}/{len} iterations  {per_sec}  ETA {eta}",
    )
    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar());
    bar.set_style(style);
    Some(bar)
}

/// Frees the per-face geometry and the V_in edge samples, which the Gather
/// stage recomputes every tick, so that the final mesh, state and events
/// are not written on top of them (on the 40962-vertex RBC they are about
/// 21 MB, and the end of a run was its peak of memory).
fn release_tick_scratch(sim: &mut Simulation) {
    if let Ok(mut g) = sim
        .resources()
        .get_mut::<crate::engine::force::FaceGeometry>()
    {
        g.0 = Vec::new();
    }
    if let Ok(mut inputs) = sim
        .resources()
        .get_mut::<crate::engine::term_inputs::TermInputs>()
        && let Some(s) = inputs.get_mut::<crate::energy::vin::VinEdgeSamples>()
    {
        s.0 = Vec::new();
    }
}

/// Re-gathers the dense mirror from the world (the last good state after a
/// failed step) without evaluating forces.
fn regather(sim: &mut Simulation) -> Result<(), RunError> {
    let mut positions = std::mem::take(&mut sim.resource_mut::<DensePositions>().0);
    let membrane = sim.membrane_mut();
    membrane.topology()?;
    membrane.gather_positions(&mut positions);
    sim.resource_mut::<DensePositions>().0 = positions;
    Ok(())
}
