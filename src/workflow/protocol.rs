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
use crate::workflow::run::RunError;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

mod ladder;
mod run;

pub use ladder::*;
pub use run::*;

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

/// Whether RON text declares a scene (its top-level value is named `Scene`).
pub fn is_scene(text: &str) -> bool {
    top_level_name(text) == Some("Scene")
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
        if !is_protocol(&text) && is_scene(&text) {
            let scene = Scene::from_ron_str(&text, path)?;
            return load_ladder(&scene, path).unwrap_or_else(|| {
                Err(file_err(
                    "a scene without `resolution: Ladder(...)`, not a protocol".into(),
                ))
            });
        }
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
                .map_err(|r| err(i, &format!("set[{k}]"), r.to_string()))?;
        }
        scene
            .refuse_ladder("a protocol's phase")
            .map_err(|r| err(i, "scene", r.to_string()))?;
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
