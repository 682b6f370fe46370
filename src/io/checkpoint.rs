//! Checkpoints: everything a killed run needs to continue exactly where it
//! was (`remembrane run SCENE --checkpoint-every N`, then
//! `remembrane run --resume DIR`).
//!
//! A checkpoint is `checkpoint.json` in the run's staging directory
//! (`DIR.incomplete/`), written atomically after every N-th iteration, so a
//! kill at any moment leaves either the previous checkpoint or the new one,
//! never half of one. It holds:
//!
//! - how to rebuild the run: the scene file's text and path, the command
//!   line's overrides and the checkpoint interval;
//! - the membrane's world entity for entity, with hecs' free list
//!   ([`WorldSnapshot`]), so dense slots and future entity handles are the
//!   same as in the uninterrupted run;
//! - the persisted resources (clock, last time step, abnormal edges handed
//!   to the next tick, remeshing statistics and events:
//!   [`crate::engine::persisted`]);
//! - the state of every stateful system, force term and recorder (control
//!   point schedules, the frame schedule, a tube's first radius);
//! - the output so far: frames written and the rows of `series.csv`.
//!
//! Random draws need no saved position: every stream is seeded by (seed,
//! stream, iteration) (`crate::util::rng`). A resumed run therefore writes the
//! same bytes as an uninterrupted one, whatever the thread counts of its
//! segments; `tests/integration/checkpoint.rs` kills real runs with SIGKILL to check it.
//! Only the per-system timings in `summary.json` cover the last segment
//! alone (its wall time is the sum of all segments).

use crate::engine::core_resources::InitialState;
pub use crate::io::output::{CHECKPOINT_FILE, OutputProgress, run_dir_of, staging_of};
use crate::io::world_snapshot::WorldSnapshot;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Format tag written into every checkpoint.
pub const CHECKPOINT_FORMAT: &str = "remembrane-checkpoint-2";

/// How to rebuild the run a checkpoint belongs to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunSource {
    /// The scene file as the run was given it (`summary.json` names it).
    pub scene_path: PathBuf,
    /// The working directory the run started in: a relative `scene_path`
    /// is resolved against it.
    pub working_dir: PathBuf,
    /// The scene file's text when the run started.
    pub scene_text: String,
    /// `--seed`.
    pub seed: Option<u64>,
    /// `--iterations`.
    pub iterations: Option<u64>,
    /// `--frames`.
    pub frames: Option<u32>,
    /// `--from` (absolute).
    pub from: Option<PathBuf>,
    /// `--check-invariants` (`Some(true)`), `--no-check-invariants`
    /// (`Some(false)`), or the build's default.
    pub check_invariants: Option<bool>,
    /// Iterations between checkpoints.
    pub every: u64,
}

/// A checkpoint file.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Checkpoint {
    /// Always [`CHECKPOINT_FORMAT`].
    pub format: String,
    /// Version of the engine that wrote it; only the same version resumes.
    pub engine: String,
    /// How to rebuild the run.
    pub run: RunSource,
    /// Iterations completed.
    pub iteration: u64,
    /// Wall time of the run's segments so far (s).
    pub wall_time_s: f64,
    /// The initial quantities of the scene's membrane (checked on resume:
    /// a changed mesh or state file would change the targets).
    pub initial: InitialState,
    /// The membrane's world.
    pub world: WorldSnapshot,
    /// Persisted resources by type name.
    pub resources: BTreeMap<String, serde_json::Value>,
    /// Stateful systems' states by system name.
    pub systems: BTreeMap<String, serde_json::Value>,
    /// Outputs so far.
    pub output: OutputProgress,
}

/// Why a checkpoint could not be read or used (names the file).
#[derive(Debug, thiserror::Error)]
#[error("{}: {reason}", path.display())]
pub struct CheckpointError {
    /// The checkpoint file.
    pub path: PathBuf,
    /// What is wrong.
    pub reason: String,
}

impl Checkpoint {
    /// Reads the checkpoint of the run whose output directory is `dir` (or
    /// its staging directory) and checks its format and engine version.
    pub fn read(dir: &Path) -> Result<Self, CheckpointError> {
        let staging = staging_of(dir);
        let path = staging.join(CHECKPOINT_FILE);
        let err = |reason: String| CheckpointError {
            path: path.clone(),
            reason,
        };
        if !staging.is_dir() {
            let dir = run_dir_of(&staging);
            let finished =
                dir.join("summary.json").is_file() || dir.join("protocol.json").is_file();
            return Err(err(if finished {
                "the run has ended (its directory has a summary.json or protocol.json); nothing to resume".into()
            } else {
                "no such staging directory: is this the --out of a run started with --checkpoint-every?".into()
            }));
        }
        let text = std::fs::read_to_string(&path).map_err(|e| {
            err(format!(
                "cannot read ({e}); the run was started without --checkpoint-every, or stopped before its first checkpoint"
            ))
        })?;
        let checkpoint: Checkpoint =
            serde_json::from_str(&text).map_err(|e| err(format!("not a checkpoint file: {e}")))?;
        if checkpoint.format != CHECKPOINT_FORMAT {
            return Err(err(format!(
                "field `format`: expected \"{CHECKPOINT_FORMAT}\", found \"{}\"",
                checkpoint.format
            )));
        }
        let engine = env!("CARGO_PKG_VERSION");
        if checkpoint.engine != engine {
            return Err(err(format!(
                "field `engine`: written by remembrane {}, this is {engine} (resume with the version that started the run)",
                checkpoint.engine
            )));
        }
        if checkpoint.run.every == 0 {
            return Err(err("field `run.every`: must be at least 1".into()));
        }
        Ok(checkpoint)
    }

    /// The checkpoint as JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("a checkpoint serialises")
    }
}

fn sim_error(e: impl std::fmt::Display) -> crate::engine::error::SimError {
    crate::engine::error::SimError::Checkpoint(e.to_string())
}

impl Checkpoint {
    /// The state of `sim` after a completed tick, with the outputs of its
    /// [`crate::io::output::RunOutput`] so far; `wall_time_s` is the run's wall
    /// time up to now.
    pub fn capture(
        sim: &crate::engine::simulation::Simulation,
        run: &RunSource,
        wall_time_s: f64,
    ) -> Result<Self, crate::engine::error::SimError> {
        let world = WorldSnapshot::capture(&sim.membrane()).map_err(sim_error)?;
        let resources = match sim
            .resources()
            .get::<crate::engine::persisted::PersistedResources>()
        {
            Ok(p) => p.save(sim.resources()).map_err(sim_error)?,
            Err(_) => BTreeMap::new(),
        };
        let systems = sim.schedule().save_states();
        let output = sim
            .resources()
            .get::<crate::io::output::OpenOutput>()
            .map_err(sim_error)?
            .get()
            .ok_or_else(|| sim_error("the run has no open output directory"))?
            .progress();
        Ok(Self {
            format: CHECKPOINT_FORMAT.into(),
            engine: env!("CARGO_PKG_VERSION").into(),
            run: run.clone(),
            iteration: sim.clock().iteration,
            wall_time_s,
            initial: *sim.resource::<InitialState>(),
            world,
            resources,
            systems,
            output,
        })
    }

    /// Puts the saved state into `sim`, a simulation freshly built from the
    /// same scene and started (its schedule fixed), before its first tick.
    pub fn restore_into(
        &self,
        sim: &mut crate::engine::simulation::Simulation,
    ) -> Result<(), crate::engine::error::SimError> {
        self.world
            .restore(sim.membrane_mut())
            .map_err(|e| sim_error(format!("world: {e}")))?;
        match sim
            .resources()
            .get::<crate::engine::persisted::PersistedResources>()
        {
            Ok(p) => p
                .restore(sim.resources(), &self.resources)
                .map_err(sim_error),
            Err(_) if self.resources.is_empty() => Ok(()),
            Err(_) => Err(sim_error(
                "the checkpoint holds resources this scene does not persist",
            )),
        }?;
        let clock = sim.clock();
        if clock.iteration != self.iteration {
            return Err(sim_error(format!(
                "field `iteration` is {}, the saved clock's {}",
                self.iteration, clock.iteration
            )));
        }
        sim.schedule_mut()
            .restore_states(&self.systems)
            .map_err(sim_error)
    }
}
