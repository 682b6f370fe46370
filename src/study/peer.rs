//! Peer engines in a study: an external command (e.g. a driver of Mem3DG)
//! solves the same problems at the same vertex counts, in the same study
//! run, so that its points go on the same charts.
//!
//! The command reads one JSON object on stdin describing the case (see
//! [`peer_spec`]) and prints one JSON object on stdout ([`PeerOutput`]).
//! Its result is kept, with the case, in
//! `OUT/peers/<peer>/<problem>/<rung>/result.json`, and reused only for
//! the same case. A peer that fails (or is not
//! installed) is reported with its reason in the study's tables; the
//! study's own cases are not affected.

use crate::params::Target;
use crate::scene::{EnergyTerm, MembraneSource, Scene};
use crate::study::{Case, Peer, Reference, Study};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// What a peer prints for a case.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PeerOutput {
    /// Engine and version.
    pub engine: String,
    /// Vertices of the peer's mesh.
    pub vertices: usize,
    /// Bending energy (Ē, same convention: a sphere gives 8πκ).
    pub energy_bending: f64,
    /// Area of the final mesh (l̄²; dynamic problems).
    #[serde(default)]
    pub area: Option<f64>,
    /// Reduced volume of the final mesh (dynamic problems).
    #[serde(default)]
    pub reduced_volume: Option<f64>,
    /// Whole wall time of the work (s).
    pub wall_s: f64,
    /// Time per step for a static problem, else the whole wall time (s).
    pub cost_s: f64,
    /// The final mesh (PLY), for dynamic problems.
    #[serde(default)]
    pub mesh: Option<PathBuf>,
    /// The peer's notes on conventions and settings.
    #[serde(default)]
    pub notes: String,
}

/// Why a case has no peer version, or why a peer gave no result.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PeerError {
    /// The case has no peer version (the reason says why).
    #[error("{0}")]
    NoVersion(&'static str),
    /// The peer's command is empty.
    #[error("the peer's command is empty")]
    EmptyCommand,
    /// The peer's program could not be started.
    #[error("cannot start `{program}`: {reason}")]
    Start {
        /// The program.
        program: String,
        /// The I/O error.
        reason: String,
    },
    /// The case could not be written to the peer.
    #[error("cannot write the case to `{program}`: {reason}")]
    WriteCase {
        /// The program.
        program: String,
        /// The I/O error.
        reason: String,
    },
    /// The peer could not be waited for.
    #[error("{0}")]
    Wait(String),
    /// The peer failed.
    #[error("exit {code}: {last}")]
    Exit {
        /// Its exit code (-1 when killed by a signal).
        code: i32,
        /// The last non-empty line of its stderr.
        last: String,
    },
    /// The peer's output is not the expected JSON.
    #[error("its output is not the expected JSON: {0}")]
    Output(String),
}

/// The JSON a peer reads for a case, or why the case has no peer version
/// (time-step problems, relative targets, other membranes).
pub fn peer_spec(
    reference: Reference,
    scene: &Scene,
    out: &Path,
) -> Result<serde_json::Value, PeerError> {
    let none = PeerError::NoVersion;
    let kappa = scene.bending_kappa().ok_or(none("no Bending term"))?;
    let level = match scene.membrane {
        MembraneSource::Icosphere { level, .. } | MembraneSource::Ellipsoid { level, .. } => level,
        _ => return Err(none("the membrane is not an icosphere or ellipsoid")),
    };
    match reference {
        Reference::SphereBending => Ok(serde_json::json!({
            "problem": "sphere", "level": level, "kappa": kappa,
        })),
        Reference::SpheroidBending => match scene.membrane {
            MembraneSource::Ellipsoid {
                semi_axes: (a, b, c),
                jitter,
                ..
            } => Ok(serde_json::json!({
                "problem": "spheroid", "level": level, "kappa": kappa,
                "semi_axes": [a, b, c], "jitter": jitter, "seed": scene.seed,
            })),
            _ => Err(none("the membrane is not an ellipsoid")),
        },
        Reference::Axisymmetric => {
            if !matches!(scene.membrane, MembraneSource::Icosphere { .. }) {
                return Err(none(
                    "the peer's deflation starts from a sphere; this rung does not",
                ));
            }
            if scene.dynamics.duration.is_some() {
                // The peer takes its own steps for the scene's iterations.
                return Err(none(
                    "the peer runs the scene's iterations; this rung sets a duration",
                ));
            }
            let penalty = |volume: bool| {
                scene.energy.iter().find_map(|t| match t {
                    EnergyTerm::Volume(p) if volume => Some((p.k, p.target)),
                    EnergyTerm::Area(p) if !volume => Some((p.k, p.target)),
                    _ => None,
                })
            };
            let (Some((kv, Target::Absolute(vt))), Some((ka, Target::Absolute(at)))) =
                (penalty(true), penalty(false))
            else {
                return Err(none(
                    "the peer needs Volume and Area terms with Absolute targets",
                ));
            };
            Ok(serde_json::json!({
                "problem": "rbc", "level": level, "kappa": kappa,
                "area_target": at, "volume_target": vt, "area_k": ka, "volume_k": kv,
                "iterations": scene.dynamics.iterations,
                "out": std::path::absolute(out).unwrap_or_else(|_| out.to_owned()),
            }))
        }
        Reference::FinestRung(_) => Err(none("a time-step problem has no peer version")),
        Reference::Tether => Err(none("the tether problem has no peer version")),
        Reference::Adhesion => Err(none("the adhesion problem has no peer version")),
    }
}

/// A peer's result as kept on disk, with the case it answers and the
/// command that answered: reused only for the same case and command.
#[derive(Serialize, Deserialize)]
struct KeptResult {
    case: serde_json::Value,
    command: Vec<String>,
    output: PeerOutput,
}

/// One peer case's outcome.
#[derive(Clone, Debug)]
pub struct PeerRun {
    /// Peer name.
    pub peer: String,
    /// The case.
    pub problem: usize,
    /// Its rung.
    pub rung: usize,
    /// The peer's output, or why there is none.
    pub result: Result<PeerOutput, PeerError>,
}

/// Where a peer case's result lives, relative to the study's output.
pub fn peer_dir(peer: &Peer, study: &Study, case: &Case) -> PathBuf {
    Path::new("peers")
        .join(&peer.name)
        .join(&study.problems[case.problem].name)
        .join(&study.problems[case.problem].rungs[case.rung].label)
}

/// Runs every peer on every case it has a version of (skipping cases with
/// a result), one at a time so that its wall times are not shared.
pub fn run_peers(
    study: &Study,
    study_path: &Path,
    cases: &[Case],
    out: &Path,
    quiet: bool,
) -> Vec<PeerRun> {
    let base = study_path.parent().unwrap_or(Path::new("."));
    let mut runs = Vec::new();
    for peer in &study.peers {
        for case in cases {
            let reference = study.problems[case.problem].reference;
            let dir = out.join(peer_dir(peer, study, case));
            let Ok(spec) = peer_spec(reference, &case.scene, &dir) else {
                continue;
            };
            let result_file = dir.join("result.json");
            let kept = std::fs::read_to_string(&result_file)
                .ok()
                .and_then(|t| serde_json::from_str::<KeptResult>(&t).ok())
                .filter(|k| k.case == spec && k.command == peer.command);
            let result = if let Some(k) = kept {
                Ok(k.output)
            } else {
                let r = run_peer(peer, base, &spec);
                if let Ok(output) = &r {
                    let kept = KeptResult {
                        case: spec.clone(),
                        command: peer.command.clone(),
                        output: output.clone(),
                    };
                    let json = serde_json::to_string_pretty(&kept).expect("serialises");
                    if let Err(e) = std::fs::create_dir_all(&dir)
                        .and_then(|()| crate::atomic_write(&result_file, json.as_bytes()))
                    {
                        eprintln!(
                            "warning: {}: cannot keep the result: {e}",
                            result_file.display()
                        );
                    }
                }
                if !quiet {
                    match &r {
                        Ok(o) => eprintln!(
                            "peer {} {}: done in {:.2} s",
                            peer.name,
                            peer_dir(peer, study, case).display(),
                            o.wall_s
                        ),
                        Err(e) => eprintln!("peer {}: FAILED: {e}", peer.name),
                    }
                }
                r
            };
            runs.push(PeerRun {
                peer: peer.name.clone(),
                problem: case.problem,
                rung: case.rung,
                result,
            });
        }
    }
    runs
}

/// Runs the peer's command on one case.
fn run_peer(peer: &Peer, base: &Path, spec: &serde_json::Value) -> Result<PeerOutput, PeerError> {
    let (program, args) = peer.command.split_first().ok_or(PeerError::EmptyCommand)?;
    let resolve = |a: &String| {
        let p = base.join(a);
        if p.is_file() {
            p.into_os_string()
        } else {
            a.into()
        }
    };
    let mut child = Command::new(resolve(program))
        .args(args.iter().map(resolve))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| PeerError::Start {
            program: program.clone(),
            reason: e.to_string(),
        })?;
    if let Some(mut stdin) = child.stdin.take() {
        // A peer that exits before reading (e.g. not installed) closes the
        // pipe: its exit status and stderr below say why.
        match stdin.write_all(spec.to_string().as_bytes()) {
            Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(PeerError::WriteCase {
                    program: program.clone(),
                    reason: e.to_string(),
                });
            }
            _ => {}
        }
    }
    let output = child
        .wait_with_output()
        .map_err(|e| PeerError::Wait(e.to_string()))?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        let last = stderr
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("");
        return Err(PeerError::Exit {
            code: output.status.code().unwrap_or(-1),
            last: last.to_string(),
        });
    }
    serde_json::from_slice(&output.stdout).map_err(|e| PeerError::Output(e.to_string()))
}
