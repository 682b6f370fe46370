//! Running a protocol's phases in order, each a normal run, and the
//! protocol as a whole (staged, resumable, renamed when it completes).

use super::{LoadedProtocol, Phase, ProtocolError, start_state};
use crate::scene::Scene;
use crate::workflow::run::{Progress, RunError, RunOptions, run_scene};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What one phase did (`protocol.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhaseRecord {
    /// Phase name (its sub-directory).
    pub name: String,
    /// Scene file.
    pub scene: PathBuf,
    /// The state it started from, if any (relative to the directory of
    /// the phases when it is one of theirs).
    pub from: Option<PathBuf>,
    /// `completed`, `blew_up`, `failed` (did not start) or `skipped`
    /// (completed before).
    pub status: String,
    /// Iterations done.
    pub iterations: u64,
    /// Simulated time (s).
    pub simulated_time: f64,
    /// Wall time (s).
    pub wall_time_s: f64,
}

/// Options of a protocol run.
#[derive(Clone, Debug)]
pub struct PhaseRunOptions {
    /// Progress reporting of each phase.
    pub progress: Progress,
    /// Override every phase's iterations (quick runs, tests).
    pub iterations: Option<u64>,
    /// Override every phase's frames.
    pub frames: Option<u32>,
    /// Check every mesh invariant after each remesh edit (`None`: the
    /// build's default, on in debug builds).
    pub check_invariants: Option<bool>,
    /// Keep phases that completed before (their `summary.json` says so)
    /// instead of running them again.
    pub skip_completed: bool,
    /// Checkpoint every phase every so many iterations (see
    /// [`crate::io::checkpoint`]).
    pub checkpoint_every: Option<u64>,
    /// Continue a killed protocol run in its staging directory: phases that
    /// completed are kept (and recorded as completed), the phase that was
    /// running resumes from its checkpoint.
    pub resume: bool,
}

/// What a protocol run records in its staging directory so that
/// `remembrane run --resume DIR` can continue it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProtocolRun {
    /// The protocol file (absolute).
    pub protocol: PathBuf,
    /// `--iterations`.
    pub iterations: Option<u64>,
    /// `--frames`.
    pub frames: Option<u32>,
    /// `--check-invariants` (`Some(true)`), `--no-check-invariants`
    /// (`Some(false)`), or the build's default.
    pub check_invariants: Option<bool>,
    /// `--checkpoint-every`.
    pub checkpoint_every: u64,
}

/// The file in a protocol's staging directory that holds its [`ProtocolRun`].
pub const PROTOCOL_RUN: &str = "protocol_run.json";

impl ProtocolRun {
    /// The protocol run being staged for `dir`, if it was started with
    /// checkpoints.
    pub fn read(dir: &Path) -> Option<Result<Self, ProtocolError>> {
        let path = crate::io::checkpoint::staging_of(dir).join(PROTOCOL_RUN);
        let text = std::fs::read_to_string(&path).ok()?;
        Some(serde_json::from_str(&text).map_err(|e| ProtocolError::Io {
            path,
            reason: format!("not a protocol run record: {e}"),
        }))
    }
}

/// The file in a phase's directory that records what it was run from
/// (its scene as RON, overrides and start), so that a completed phase is
/// reused only when nothing it depends on changed.
pub const PHASE_FINGERPRINT: &str = "phase.json";

/// A phase that failed in [`run_phases`].
#[derive(Debug)]
pub struct PhaseFailure {
    /// Its index.
    pub index: usize,
    /// Its error.
    pub error: RunError,
    /// The records of the phases up to and including it.
    pub records: Vec<PhaseRecord>,
}

/// What a phase's result depends on: a completed phase is kept only if it
/// was run from exactly this.
fn phase_fingerprint(
    scene: &Scene,
    options: &PhaseRunOptions,
    from: Option<&Path>,
    refine: u32,
) -> String {
    serde_json::json!({
        "scene": scene.to_ron_string().unwrap_or_default(),
        "iterations": options.iterations,
        "frames": options.frames,
        "from": from,
        "refine": refine,
    })
    .to_string()
}

/// The run options of a phase run into `out` from `from`.
fn phase_run_options(
    scene: &Scene,
    out: &Path,
    from: Option<PathBuf>,
    options: &PhaseRunOptions,
) -> RunOptions {
    let checkpoint =
        options
            .checkpoint_every
            .map(|every| crate::workflow::run::CheckpointSettings {
                every,
                // The phase's scene with its changes: RON writes floats in
                // their shortest round-trip form.
                scene_text: scene.to_ron_string().unwrap_or_default(),
            });
    RunOptions {
        overwrite: true,
        iterations: options.iterations,
        frames: options.frames,
        from,
        progress: options.progress,
        check_invariants: options.check_invariants,
        checkpoint,
        ..RunOptions::quiet(out)
    }
}

/// A phase's record with `status` and no iterations run (yet).
fn phase_record(
    phase: &Phase,
    scene_path: &Path,
    from: Option<PathBuf>,
    status: &str,
) -> PhaseRecord {
    PhaseRecord {
        name: phase.name.clone(),
        scene: scene_path.to_path_buf(),
        from,
        status: status.into(),
        iterations: 0,
        simulated_time: 0.0,
        wall_time_s: 0.0,
    }
}

/// Runs `phases` (checked, with their `scenes`) in order into
/// `dir/<phase>`; relative start states resolve from `base`. Returns the
/// records, or the failed phase with the records so far.
pub fn run_phases(
    phases: &[Phase],
    scenes: &[(Scene, PathBuf)],
    base: &Path,
    dir: &Path,
    options: &PhaseRunOptions,
) -> Result<Vec<PhaseRecord>, Box<PhaseFailure>> {
    let mut records = Vec::with_capacity(phases.len());
    // Once a phase runs, every later one runs again (its start changed).
    let mut ran_one = false;
    for (i, (phase, (scene, scene_path))) in phases.iter().zip(scenes).enumerate() {
        let out = dir.join(&phase.name);
        let mut from = start_state(phases, i, dir, base);
        // Recorded relative to the protocol's directory where it is in it
        // (the directory is renamed when the protocol completes).
        let from_record = from.as_ref().map(|f| {
            f.strip_prefix(dir)
                .map_or_else(|_| f.clone(), Path::to_path_buf)
        });
        // What the phase's result depends on: a completed phase is kept
        // only if it was run from exactly this.
        let fingerprint = phase_fingerprint(scene, options, from_record.as_deref(), phase.refine);
        let fingerprint_file = out.join(PHASE_FINGERPRINT);
        if (options.skip_completed || options.resume)
            && !ran_one
            && std::fs::read_to_string(&fingerprint_file).is_ok_and(|f| f == fingerprint)
            && let Some(done) =
                completed_record(phase, scene_path, from_record.clone(), &out, options.resume)
        {
            records.push(done);
            continue;
        }
        // A refined start is the scene's own membrane source (a state with
        // `refine`), so that the checkpoint's scene text holds it.
        let refined;
        let scene = match (from.take(), phase.refine) {
            (Some(f), refine) if refine > 0 => {
                let mut s = scene.clone();
                s.membrane = crate::scene::MembraneSource::State {
                    path: std::path::absolute(&f).unwrap_or(f),
                    refine,
                };
                refined = s;
                &refined
            }
            (f, _) => {
                from = f;
                scene
            }
        };
        let resume_phase = options.resume
            && !ran_one
            && crate::io::checkpoint::staging_of(&out)
                .join(crate::io::checkpoint::CHECKPOINT_FILE)
                .exists();
        ran_one = true;
        let run_options = phase_run_options(scene, &out, from.clone(), options);
        if options.progress != Progress::Quiet {
            let resumed = if resume_phase { " (resumed)" } else { "" };
            eprintln!(
                "phase {} of {}: {}{resumed}",
                i + 1,
                phases.len(),
                phase.name
            );
        }
        let outcome = if resume_phase {
            crate::workflow::run::resume_run(&out, options.progress, options.checkpoint_every)
        } else {
            run_scene(scene, scene_path, &run_options, |_| Ok(()))
        };
        match outcome {
            Ok(s) => {
                // Not fatal: without it the phase just runs again next time.
                let _ = crate::atomic_write(&fingerprint_file, fingerprint.as_bytes());
                records.push(PhaseRecord {
                    iterations: s.iterations,
                    simulated_time: s.simulated_time,
                    wall_time_s: s.wall_time_s,
                    ..phase_record(phase, scene_path, from_record, "completed")
                })
            }
            Err(e) => {
                let status = match e {
                    RunError::Stopped { .. } => "blew_up",
                    _ => "failed",
                };
                records.push(phase_record(phase, scene_path, from_record, status));
                return Err(Box::new(PhaseFailure {
                    index: i,
                    error: e,
                    records,
                }));
            }
        }
    }
    Ok(records)
}

/// The record of a phase whose directory holds a completed run: `skipped`
/// (reused by a sweep), or `completed` with its wall time when a resumed
/// protocol run keeps what it completed before it was stopped.
fn completed_record(
    phase: &Phase,
    scene: &Path,
    from: Option<PathBuf>,
    out: &Path,
    resumed: bool,
) -> Option<PhaseRecord> {
    let v = crate::io::summary::RunSummary::read(out).ok()?;
    (v.status == crate::io::summary::RunStatus::Completed && out.join("state.json").exists()).then(
        || PhaseRecord {
            name: phase.name.clone(),
            scene: scene.to_owned(),
            from,
            status: if resumed { "completed" } else { "skipped" }.into(),
            iterations: v.iterations,
            simulated_time: v.simulated_time,
            wall_time_s: if resumed { v.wall_time_s } else { 0.0 },
        },
    )
}

/// `protocol.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ProtocolSummary {
    /// Protocol name.
    pub name: String,
    /// The protocol file.
    pub protocol_file: PathBuf,
    /// `completed` or `failed`.
    pub status: String,
    /// Every phase run.
    pub phases: Vec<PhaseRecord>,
}

/// Runs a loaded protocol into `out` (staged as `out.incomplete`).
pub fn run_protocol(
    loaded: &LoadedProtocol,
    out: &Path,
    overwrite: bool,
    options: &PhaseRunOptions,
) -> Result<ProtocolSummary, ProtocolError> {
    let io = |path: &Path, e: std::io::Error| ProtocolError::Io {
        path: path.to_owned(),
        reason: e.to_string(),
    };
    let staging = if options.resume {
        // The staging directory of the stopped run, as it was left.
        crate::io::checkpoint::staging_of(out)
    } else {
        crate::io::output::prepare_staging(out, overwrite).map_err(|e| match e {
            crate::io::output::OutputError::Exists(dir) => ProtocolError::Exists(dir),
            crate::io::output::OutputError::Write { path, reason } => {
                ProtocolError::Io { path, reason }
            }
        })?
    };
    if let Some(every) = options.checkpoint_every
        && !options.resume
    {
        let record = ProtocolRun {
            protocol: std::path::absolute(&loaded.path).unwrap_or_else(|_| loaded.path.clone()),
            iterations: options.iterations,
            frames: options.frames,
            check_invariants: options.check_invariants,
            checkpoint_every: every,
        };
        let path = staging.join(PROTOCOL_RUN);
        let json = serde_json::to_string_pretty(&record).expect("the record serialises");
        crate::atomic_write(&path, json.as_bytes()).map_err(|e| io(&path, e))?;
    }
    let base = loaded.path.parent().unwrap_or(Path::new("."));
    let result = run_phases(
        &loaded.protocol.phases,
        &loaded.scenes,
        base,
        &staging,
        options,
    );
    let (status, phases, failure) = match result {
        Ok(records) => ("completed", records, None),
        Err(f) => {
            let PhaseFailure {
                index,
                error,
                records,
            } = *f;
            ("failed", records, Some((index, error)))
        }
    };
    let summary = ProtocolSummary {
        name: loaded.protocol.name.clone(),
        protocol_file: std::path::absolute(&loaded.path).unwrap_or_else(|_| loaded.path.clone()),
        status: status.into(),
        phases,
    };
    let json = serde_json::to_string_pretty(&summary).expect("the summary serialises");
    let index = staging.join("protocol.json");
    crate::atomic_write(&index, json.as_bytes()).map_err(|e| io(&index, e))?;
    if let Some((i, source)) = failure {
        return Err(ProtocolError::Phase {
            phase: loaded.protocol.phases[i].name.clone(),
            source: Box::new(source),
            dir: staging,
        });
    }
    // A finished protocol is not resumed: its run record goes.
    let record = staging.join(PROTOCOL_RUN);
    if record.exists() {
        std::fs::remove_file(&record).map_err(|e| io(&record, e))?;
    }
    std::fs::rename(&staging, out).map_err(|e| io(out, e))?;
    Ok(summary)
}
