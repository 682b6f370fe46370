//! Protocols: phases run in order, each a normal run, the later ones
//! starting from an earlier phase's final state.
//!
//! ```ron
//! Protocol(
//!     name: "rbc_soft_to_stiff",
//!     phases: [
//!         (name: "soft", scene: "red_blood_cell.ron", iterations: 25000),
//!         (name: "stiff", scene: "red_blood_cell_stiff.ron", start: Previous, iterations: 25000),
//!     ],
//! )
//! ```
//!
//! `remembrane run PROTOCOL --out DIR` writes `DIR/<phase>/` for every phase
//! (each exactly what `remembrane run` writes) and `DIR/protocol.json`. The
//! whole protocol is staged in `DIR.incomplete` and renamed when the last
//! phase has completed, so a failed or killed protocol never leaves a
//! directory that looks like a result. A sweep can declare the same phases
//! as its shared start ([`crate::workflow::sweep::Sweep::phases`]).

use crate::scene::setting::Setting;
use crate::scene::{Scene, SceneError};
use crate::workflow::run::{Progress, RunError, RunOptions, run_scene};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A protocol file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Protocol {
    /// Name (used in messages and job names).
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// The phases, run in order.
    pub phases: Vec<Phase>,
}

/// One phase: a scene with changes, started from the scene's own membrane
/// or from an earlier phase's final state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Phase {
    /// Name: the phase's sub-directory.
    pub name: String,
    /// Scene file, relative to the protocol (or sweep) file's folder.
    pub scene: PathBuf,
    /// Where the membrane starts (default: the scene's own membrane).
    #[serde(default)]
    pub start: Start,
    /// Iterations (default: the scene's).
    #[serde(default)]
    pub iterations: Option<u64>,
    /// Simulated duration (s; default: the scene's).
    #[serde(default)]
    pub duration: Option<f64>,
    /// Seed (default: the scene's).
    #[serde(default)]
    pub seed: Option<u64>,
    /// Parameter changes, as in sweeps (`Kappa(10.0)`, `VolumeStrength(40.0)`, ...).
    #[serde(default)]
    pub set: Vec<Setting>,
    /// Times the start state's triangles are split into four at their
    /// edges' midpoints (default 0, at most 3; needs a `start` state): a
    /// finer mesh of the shape the phase starts from, for a scene at a
    /// finer `resolution` (continuation from coarse to fine, as in the
    /// Surface Evolver).
    #[serde(default)]
    pub refine: u32,
}

/// Where a phase's membrane starts.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Start {
    /// The scene's own membrane.
    #[default]
    Scene,
    /// The final state of the phase before it.
    Previous,
    /// The final state of the named earlier phase.
    Phase(String),
    /// A `state.json` of another run (relative to the protocol file).
    State(PathBuf),
}

/// Why a protocol cannot run.
#[derive(Debug, thiserror::Error)]
pub enum ProtocolError {
    /// The file is unreadable, malformed or inconsistent.
    #[error("{}: {reason}", path.display())]
    File {
        /// The protocol (or sweep) file.
        path: PathBuf,
        /// What is wrong, with the field.
        reason: String,
    },
    /// A phase's scene is invalid.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The output directory exists.
    #[error("{}: exists (use --overwrite to replace it)", .0.display())]
    Exists(PathBuf),
    /// A phase failed; the outputs so far are in `dir`.
    #[error("phase `{phase}`: {source} (the protocol's outputs so far are in {})", dir.display())]
    Phase {
        /// The failed phase.
        phase: String,
        /// Its error.
        source: Box<RunError>,
        /// Where the protocol's outputs are.
        dir: PathBuf,
    },
    /// The protocol's own files could not be written.
    #[error("{}: {reason}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The error.
        reason: String,
    },
}

impl ProtocolError {
    /// Exit code: 2 for bad input, 1 for a run that failed.
    pub fn exit_code(&self) -> u8 {
        match self {
            ProtocolError::File { .. } | ProtocolError::Scene(_) | ProtocolError::Exists(_) => 2,
            ProtocolError::Phase { source, .. } => source.exit_code(),
            ProtocolError::Io { .. } => 1,
        }
    }
}

/// Whether RON text declares a protocol (its top-level value is named
/// `Protocol`), as opposed to a scene.
pub fn is_protocol(text: &str) -> bool {
    top_level_name(text) == Some("Protocol")
}

/// The name before the first `(` of RON text, comments skipped.
pub(crate) fn top_level_name(text: &str) -> Option<&str> {
    let mut rest = text;
    loop {
        rest = rest.trim_start();
        if let Some(r) = rest.strip_prefix("//") {
            rest = r.split_once('\n').map_or("", |(_, after)| after);
        } else if let Some(r) = rest.strip_prefix("/*") {
            rest = r.split_once("*/").map_or("", |(_, after)| after);
        } else if rest.starts_with("#![") {
            rest = rest.split_once(']').map_or("", |(_, after)| after);
        } else {
            break;
        }
    }
    let end = rest
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    (end > 0).then(|| &rest[..end])
}

/// A loaded protocol with every phase's scene (changes applied).
#[derive(Clone, Debug)]
pub struct LoadedProtocol {
    /// The file.
    pub path: PathBuf,
    /// The protocol.
    pub protocol: Protocol,
    /// Each phase's scene and scene path.
    pub scenes: Vec<(Scene, PathBuf)>,
}

impl Protocol {
    /// Reads, parses and checks a protocol file: every scene loads, every
    /// change applies, names are unique and starts refer to earlier phases.
    pub fn load(path: &Path) -> Result<LoadedProtocol, ProtocolError> {
        let file_err = |reason: String| ProtocolError::File {
            path: path.to_owned(),
            reason,
        };
        let text =
            std::fs::read_to_string(path).map_err(|e| file_err(format!("cannot read: {e}")))?;
        let protocol: Protocol = crate::scene::setting::ron_options()
            .from_str(&text)
            .map_err(|e| {
                file_err(format!(
                    "{}:{}: {}",
                    e.span.start.line, e.span.start.col, e.code
                ))
            })?;
        if protocol.phases.is_empty() {
            return Err(file_err(
                "field `phases`: a protocol needs at least one phase".into(),
            ));
        }
        let scenes = check_phases(&protocol.phases, path, "phases")?;
        Ok(LoadedProtocol {
            path: path.to_owned(),
            protocol,
            scenes,
        })
    }
}

/// Checks `phases` declared in `file` (under `field`) and returns each
/// phase's scene with its changes applied, and its path.
pub fn check_phases(
    phases: &[Phase],
    file: &Path,
    field: &str,
) -> Result<Vec<(Scene, PathBuf)>, ProtocolError> {
    let err = |i: usize, sub: &str, reason: String| ProtocolError::File {
        path: file.to_owned(),
        reason: format!("field `{field}[{i}].{sub}`: {reason}"),
    };
    let base = file.parent().unwrap_or(Path::new("."));
    let mut scenes = Vec::with_capacity(phases.len());
    for (i, p) in phases.iter().enumerate() {
        if !crate::scene::setting::valid_name(&p.name) {
            return Err(err(
                i,
                "name",
                format!("`{}` must be a plain directory name", p.name),
            ));
        }
        if phases[..i].iter().any(|q| q.name == p.name) {
            return Err(err(i, "name", format!("`{}` is used twice", p.name)));
        }
        if p.refine > 0 && p.start == Start::Scene {
            return Err(err(
                i,
                "refine",
                "refines the state the phase starts from: set `start` (Previous, Phase or State)"
                    .into(),
            ));
        }
        if p.refine > 3 {
            return Err(err(
                i,
                "refine",
                format!("must be at most 3 (64 times the faces; got {})", p.refine),
            ));
        }
        match &p.start {
            Start::Previous if i == 0 => {
                return Err(err(
                    i,
                    "start",
                    "the first phase has no previous phase".into(),
                ));
            }
            Start::Phase(n) if !phases[..i].iter().any(|q| &q.name == n) => {
                let earlier: Vec<&str> = phases[..i].iter().map(|q| q.name.as_str()).collect();
                return Err(err(
                    i,
                    "start",
                    format!(
                        "no earlier phase `{n}` (earlier phases: {})",
                        if earlier.is_empty() {
                            "none".to_string()
                        } else {
                            earlier.join(", ")
                        }
                    ),
                ));
            }
            _ => {}
        }
        if let Some(t) = p.duration
            && !(t.is_finite() && t > 0.0)
        {
            return Err(err(
                i,
                "duration",
                format!("must be a positive time in s (got {t})"),
            ));
        }
        let scene_path = base.join(&p.scene);
        let mut scene = Scene::load(&scene_path)?;
        for (k, s) in p.set.iter().enumerate() {
            s.apply(&mut scene)
                .map_err(|r| err(i, &format!("set[{k}]"), r))?;
        }
        if let Some(n) = p.iterations {
            scene.dynamics.iterations = n;
        }
        if p.duration.is_some() {
            scene.dynamics.duration = p.duration;
        }
        if let Some(s) = p.seed {
            scene.seed = s;
        }
        scenes.push((scene, scene_path));
    }
    Ok(scenes)
}

/// The `state.json` phase `index` starts from, with earlier phases'
/// directories in `phases_dir` and relative paths from `base`.
pub fn start_state(
    phases: &[Phase],
    index: usize,
    phases_dir: &Path,
    base: &Path,
) -> Option<PathBuf> {
    match &phases[index].start {
        Start::Scene => None,
        Start::Previous => Some(phases_dir.join(&phases[index - 1].name).join("state.json")),
        Start::Phase(n) => Some(phases_dir.join(n).join("state.json")),
        Start::State(p) => Some(base.join(p)),
    }
}

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
    /// Check every mesh invariant after each remesh edit.
    pub check_invariants: bool,
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
    /// `--check-invariants`.
    pub check_invariants: bool,
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
        out: out.to_path_buf(),
        overwrite: true,
        seed: None,
        iterations: options.iterations,
        frames: options.frames,
        from,
        progress: options.progress,
        check_invariants: options.check_invariants,
        checkpoint,
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
    let v = crate::workflow::run::RunSummary::read(out).ok()?;
    (v.status == crate::workflow::run::RunStatus::Completed && out.join("state.json").exists())
        .then(|| PhaseRecord {
            name: phase.name.clone(),
            scene: scene.to_owned(),
            from,
            status: if resumed { "completed" } else { "skipped" }.into(),
            iterations: v.iterations,
            simulated_time: v.simulated_time,
            wall_time_s: if resumed { v.wall_time_s } else { 0.0 },
        })
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_top_level_name_skips_comments() {
        assert!(is_protocol(
            "// a\n/* b */\n  Protocol(name: \"x\", phases: [])"
        ));
        assert!(!is_protocol(
            "// Protocol(\nScene(membrane: Icosphere(level: 1))"
        ));
        assert!(!is_protocol("(name: \"x\")"));
        assert_eq!(
            top_level_name("#![enable(implicit_some)]\nSweep("),
            Some("Sweep")
        );
    }
}
