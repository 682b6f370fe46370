//! The vesicle shape diagram: the bending energy E_b/8πκ against the reduced
//! volume v on the prolate, oblate and stomatocyte branches (Seifert, Berndl
//! & Lipowsky, Phys. Rev. A 44, 1182 (1991)), found by the minimiser and set
//! beside the axisymmetric solver's curves for the same continuum problem.
//!
//! ```ron
//! ShapeDiagram(
//!     name: "vesicle_shape_diagram",
//!     reduced_volumes: [0.95, 0.9, 0.85, 0.8, 0.75, 0.7, 0.65, 0.6, 0.55],
//!     branches: [
//!         (name: "prolate", scene: "prolate.ron", reference: Prolate),
//!         (name: "oblate", scene: "oblate.ron", reference: Oblate),
//!         (name: "stomatocyte", scene: "stomatocyte.ron", reference: Stomatocyte,
//!          reduced_volumes: Some([0.65, 0.6, 0.55])),
//!     ],
//!     meshes: [
//!         (label: "642", h: 1.0),
//!         (label: "2562", h: 0.5, set: [
//!             ("membrane.Ellipsoid.level", 4),
//!             ("membrane.Axisymmetric.mean_edge_length", 0.5),
//!             ("resolution", {"EdgeLength": 0.5}),
//!         ]),
//!     ],
//! )
//! ```
//!
//! `remembrane diagram FILE --out DIR` walks every branch on every mesh.
//! The first reduced volume starts from the branch scene's own membrane,
//! whose shape selects the branch (the stomatocyte's is the continuum's
//! own cup, `Axisymmetric(branch: Stomatocyte, ...)`, since no deflated
//! spheroid reaches it); every later one starts from the final
//! state of the one before (`DIR/<mesh>/<branch>/v<v>/`, each a normal run
//! directory). The scene must hold the area with exact constraints and
//! minimise: the walk sets `constraints.volume` to `Reduced(v)`. Then it
//! writes `diagram.csv`, `diagram.md`, `diagram.json` and `diagram.png`
//! (measured points over the reference curves), and prints the table.
//! Everything is staged in `DIR.incomplete` and renamed only when every
//! point completed, so a failed diagram never looks like a result.

use crate::scene::setting::Setting;
use crate::scene::{Scene, SceneError};
use crate::study::axisymmetric::{self, Branch};
use crate::workflow::run::{Progress, RunOptions, RunSummary, run_scene};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A shape-diagram file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShapeDiagram {
    /// Name (messages, the default output directory).
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Reduced volumes walked, in order (each in (0, 1)).
    pub reduced_volumes: Vec<f64>,
    /// The branches.
    pub branches: Vec<DiagramBranch>,
    /// The meshes every branch is walked on (default: the scenes as
    /// written, labelled `scene`).
    #[serde(default = "default_meshes")]
    pub meshes: Vec<DiagramMesh>,
}

fn default_meshes() -> Vec<DiagramMesh> {
    vec![DiagramMesh {
        label: "scene".into(),
        set: Vec::new(),
        h: None,
    }]
}

/// One branch: the scene whose starting shape selects it, and the
/// reference branch it is compared with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagramBranch {
    /// Name (a directory name and the table's label).
    pub name: String,
    /// Scene file, relative to the diagram file's folder.
    pub scene: PathBuf,
    /// The axisymmetric solver's branch it is compared with.
    pub reference: Branch,
    /// Reduced volumes of this branch, walked in order (default: the
    /// diagram's), e.g. where the branch exists.
    #[serde(default)]
    pub reduced_volumes: Option<Vec<f64>>,
    /// Labels of the meshes this branch is walked on (default: all).
    #[serde(default)]
    pub meshes: Option<Vec<String>>,
}

/// One mesh every branch is walked on: changes to each branch scene by
/// dotted path (see [`crate::scene::overrides`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagramMesh {
    /// Label (a directory name and the table's label).
    pub label: String,
    /// Changes, e.g. `("membrane.Ellipsoid.level", 4)`. A change that
    /// names a membrane kind (`membrane.Ellipsoid...`) applies only to the
    /// branches whose scene starts from that kind, and must apply to one.
    #[serde(default)]
    pub set: Vec<(String, serde_json::Value)>,
    /// The mesh's edge length h (l̄), if it is a rung of a refinement: the
    /// two finest meshes with `h` give a Richardson-extrapolated energy
    /// (the discrete energy's error is O(h²)).
    #[serde(default)]
    pub h: Option<f64>,
}

/// Why a diagram cannot run or did not complete.
#[derive(Debug, thiserror::Error)]
pub enum DiagramError {
    /// The diagram file is unreadable or invalid.
    #[error("{}: {reason}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// Why (naming the field).
        reason: String,
    },
    /// A branch scene is invalid.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The output directory exists.
    #[error("{} exists (use --overwrite to replace it)", .0.display())]
    Exists(PathBuf),
    /// Some points did not complete; everything is in the staging
    /// directory.
    #[error("{failed} of {total} points did not complete (first: {first}); the outputs are in {}", dir.display())]
    Points {
        /// Points that failed or were not reached.
        failed: usize,
        /// All points.
        total: usize,
        /// The first failure.
        first: String,
        /// The staging directory.
        dir: PathBuf,
    },
    /// The diagram's own files could not be written.
    #[error("{}: {reason}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The error.
        reason: String,
    },
}

impl DiagramError {
    /// Exit code: 2 for bad input, 1 for a diagram that failed.
    pub fn exit_code(&self) -> u8 {
        match self {
            DiagramError::File { .. } | DiagramError::Scene(_) | DiagramError::Exists(_) => 2,
            DiagramError::Points { .. } | DiagramError::Io { .. } => 1,
        }
    }
}

/// Whether RON text declares a shape diagram.
pub fn is_shape_diagram(text: &str) -> bool {
    crate::workflow::protocol::top_level_name(text) == Some("ShapeDiagram")
}

/// One walk: a branch on a mesh, with the scene of every point.
#[derive(Clone, Debug)]
pub struct Walk {
    /// The mesh's label.
    pub mesh: String,
    /// The branch's name.
    pub branch: String,
    /// Its reference branch.
    pub reference: Branch,
    /// The branch scene's file.
    pub scene_path: PathBuf,
    /// Each point's reduced volume and scene, in walking order.
    pub points: Vec<(f64, Scene)>,
}

/// A loaded, checked diagram.
#[derive(Clone, Debug)]
pub struct LoadedDiagram {
    /// The file.
    pub path: PathBuf,
    /// The diagram.
    pub diagram: ShapeDiagram,
    /// Every walk, mesh by mesh.
    pub walks: Vec<Walk>,
}

impl ShapeDiagram {
    /// Reads and checks a diagram file: names are plain and unique, the
    /// reduced volumes lie in (0, 1), every scene loads with every mesh's
    /// changes, holds the area exactly, minimises and has a bending term.
    pub fn load(path: &Path) -> Result<LoadedDiagram, DiagramError> {
        let err = |reason: String| DiagramError::File {
            path: path.to_owned(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(format!("cannot read: {e}")))?;
        let diagram: ShapeDiagram = crate::scene::setting::ron_options()
            .from_str(&text)
            .map_err(|e| {
                err(format!(
                    "{}:{}: {}",
                    e.span.start.line, e.span.start.col, e.code
                ))
            })?;
        let check_volumes = |field: &str, vs: &[f64]| -> Result<(), DiagramError> {
            if vs.is_empty() {
                return Err(err(format!("field `{field}`: give at least one")));
            }
            match vs
                .iter()
                .find(|v| !(v.is_finite() && **v > 0.0 && **v < 1.0))
            {
                Some(v) => Err(err(format!(
                    "field `{field}`: a reduced volume must be in (0, 1) (got {v})"
                ))),
                None => Ok(()),
            }
        };
        check_volumes("reduced_volumes", &diagram.reduced_volumes)?;
        if diagram.branches.is_empty() {
            return Err(err("field `branches`: give at least one".into()));
        }
        if diagram.meshes.is_empty() {
            return Err(err("field `meshes`: give at least one".into()));
        }
        for (field, names) in [
            (
                "branches",
                diagram.branches.iter().map(|b| &b.name).collect::<Vec<_>>(),
            ),
            ("meshes", diagram.meshes.iter().map(|m| &m.label).collect()),
        ] {
            for (i, n) in names.iter().enumerate() {
                if !crate::scene::setting::valid_name(n) {
                    return Err(err(format!(
                        "field `{field}[{i}]`: `{n}` must be a plain directory name"
                    )));
                }
                if names[..i].contains(n) {
                    return Err(err(format!("field `{field}[{i}]`: `{n}` is used twice")));
                }
            }
        }
        let base = path.parent().unwrap_or(Path::new("."));
        let mut walks = Vec::new();
        for (i, branch) in diagram.branches.iter().enumerate() {
            if let Some(labels) = &branch.meshes
                && let Some(l) = labels
                    .iter()
                    .find(|l| !diagram.meshes.iter().any(|m| &&m.label == l))
            {
                return Err(err(format!(
                    "field `branches[{i}].meshes`: no mesh `{l}` in field `meshes`"
                )));
            }
        }
        // Which of each mesh's changes some branch took (one naming a
        // membrane kind applies only to scenes of that kind).
        let mut applied: Vec<Vec<bool>> = diagram
            .meshes
            .iter()
            .map(|m| vec![false; m.set.len()])
            .collect();
        for (m, mesh) in diagram.meshes.iter().enumerate() {
            for (i, branch) in diagram.branches.iter().enumerate() {
                if branch
                    .meshes
                    .as_ref()
                    .is_some_and(|m| !m.contains(&mesh.label))
                {
                    continue;
                }
                let volumes = branch
                    .reduced_volumes
                    .as_deref()
                    .unwrap_or(&diagram.reduced_volumes);
                check_volumes(&format!("branches[{i}].reduced_volumes"), volumes)?;
                let scene_path = base.join(&branch.scene);
                let scene = Scene::load(&scene_path)?;
                let changes = changes_for(&mesh.set, &scene);
                for (k, (path, _)) in mesh.set.iter().enumerate() {
                    if changes.iter().any(|(p, _)| p == path) {
                        applied[m][k] = true;
                    }
                }
                let scene = crate::scene::overrides::set_parameters(&scene, &scene_path, &changes)?;
                if !matches!(scene.dynamics.method, crate::params::Method::Minimise(_)) {
                    return Err(err(format!(
                        "field `branches[{i}].scene`: {} does not minimise (a shape diagram holds \
                         equilibrium shapes: give `dynamics.method: Minimise(...)`)",
                        scene_path.display()
                    )));
                }
                if crate::study::bending_kappa(&scene).is_none() {
                    return Err(err(format!(
                        "field `branches[{i}].scene`: {} has no Bending term",
                        scene_path.display()
                    )));
                }
                let mut points = Vec::with_capacity(volumes.len());
                for &v in volumes {
                    let mut s = scene.clone();
                    Setting::ReducedVolume(v).apply(&mut s).map_err(|r| {
                        err(format!(
                            "field `branches[{i}].scene`: {}: {r}",
                            scene_path.display()
                        ))
                    })?;
                    points.push((v, s));
                }
                walks.push(Walk {
                    mesh: mesh.label.clone(),
                    branch: branch.name.clone(),
                    reference: branch.reference,
                    scene_path,
                    points,
                });
            }
        }
        for (m, mesh) in diagram.meshes.iter().enumerate() {
            if let Some(k) = applied[m].iter().position(|a| !a) {
                return Err(err(format!(
                    "field `meshes[{m}].set[{k}]`: `{}` names a membrane that no branch \
                     walked on mesh `{}` starts from",
                    mesh.set[k].0, mesh.label
                )));
            }
        }
        Ok(LoadedDiagram {
            path: path.to_owned(),
            diagram,
            walks,
        })
    }
}

/// The changes of `set` that apply to `scene`: all but those naming a
/// membrane kind other than the scene's (`membrane.Ellipsoid.level` is
/// skipped for a scene that starts from `Axisymmetric`), so that one mesh
/// can refine branches started from different kinds of membrane.
fn changes_for(
    set: &[(String, serde_json::Value)],
    scene: &Scene,
) -> Vec<(String, serde_json::Value)> {
    let kind = serde_json::to_value(&scene.membrane)
        .ok()
        .and_then(|v| v.as_object().and_then(|o| o.keys().next().cloned()));
    set.iter()
        .filter(|(path, _)| {
            let mut segments = path.split('.');
            match (segments.next(), segments.next()) {
                (Some("membrane"), Some(named)) if named.starts_with(char::is_uppercase) => {
                    kind.as_deref() == Some(named)
                }
                _ => true,
            }
        })
        .cloned()
        .collect()
}

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
fn extrapolate(meshes: &[DiagramMesh], points: &[DiagramPoint]) -> Vec<ExtrapolatedPoint> {
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
const CURVE_SEGMENTS: usize = 200;
/// Spacing of the drawn curves in v.
const CURVE_STEP: f64 = 0.005;

/// The directory name of the point at `v`.
fn point_dir(v: f64) -> String {
    format!("v{v}")
}

/// Runs the diagram into `out` (staged as `out.incomplete`).
pub fn run_diagram(
    loaded: &LoadedDiagram,
    out: &Path,
    options: &DiagramOptions,
) -> Result<DiagramSummary, DiagramError> {
    let started = std::time::Instant::now();
    let io = |path: &Path, e: std::io::Error| DiagramError::Io {
        path: path.to_owned(),
        reason: e.to_string(),
    };
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

    // The continuum at every walked point, branch by branch.
    let mut references: Vec<(Branch, f64, Option<ReferenceValue>)> = Vec::new();
    for w in &walks {
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

    let reference_at = |b: Branch, v: f64| {
        references
            .iter()
            .find(|(rb, rv, _)| *rb == b && *rv == v)
            .and_then(|(_, _, r)| *r)
    };

    let mut points = Vec::new();
    for w in &walks {
        let mut from: Option<PathBuf> = None;
        let mut failed = false;
        for (v, scene) in &w.points {
            let dir = staging.join(&w.mesh).join(&w.branch).join(point_dir(*v));
            let reference = reference_at(w.reference, *v);
            let mut point = DiagramPoint {
                mesh: w.mesh.clone(),
                branch: w.branch.clone(),
                reference_branch: w.reference,
                target: *v,
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
            };
            if failed {
                points.push(point);
                continue;
            }
            let run_options = RunOptions {
                out: dir.clone(),
                overwrite: true,
                seed: None,
                iterations: options.iterations,
                frames: None,
                from: from.clone(),
                progress: Progress::Quiet,
                check_invariants: false,
                checkpoint: None,
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
fn fill_point(point: &mut DiagramPoint, s: &RunSummary, scene: &Scene) {
    let kappa = crate::study::bending_kappa(scene).unwrap_or(f64::NAN);
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
    point.reduced_volume = s.last.reduced_volume;
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

fn progress_line(p: &DiagramPoint) -> String {
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
fn reference_curves(walks: &[&Walk]) -> Vec<(Branch, Vec<(f64, f64)>)> {
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
fn crossings(points: &[DiagramPoint], curves: &[(Branch, Vec<(f64, f64)>)]) -> Vec<Crossing> {
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
fn crossing(a: &[(f64, f64)], b: &[(f64, f64)]) -> Option<(f64, f64)> {
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

/// Writes `diagram.csv`, `diagram.md`, `diagram.json` and `diagram.png`.
fn write_outputs(dir: &Path, s: &DiagramSummary) -> Result<(), (PathBuf, std::io::Error)> {
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        crate::atomic_write(&path, bytes).map_err(|e| (path, e))
    };
    write("diagram.csv", csv(s).as_bytes())?;
    write("diagram.md", markdown(s).as_bytes())?;
    let json = serde_json::to_string_pretty(s).unwrap_or_default();
    write("diagram.json", json.as_bytes())?;
    write("diagram.png", &chart(s))
}

fn num(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        String::new()
    }
}

/// `diagram.csv`: one row per point.
pub fn csv(s: &DiagramSummary) -> String {
    let mut out = String::from(
        "mesh,branch,reference_branch,target_v,status,vertices,v,energy_over_8pi_kappa,\
         reference,reference_error,relative_error,pressure,reference_pressure,tension,\
         reference_tension,class,converged,stopped_by,iterations,remesh_events,wall_time_s\n",
    );
    for p in &s.points {
        let r = p.reference;
        let row = [
            p.mesh.clone(),
            p.branch.clone(),
            p.reference_branch.to_string(),
            num(p.target),
            p.status.replace([',', '\n'], ";"),
            p.vertices.to_string(),
            num(p.reduced_volume),
            num(p.energy),
            r.map_or(String::new(), |r| num(r.energy)),
            r.map_or(String::new(), |r| num(r.error)),
            p.relative_error.map_or(String::new(), num),
            num(p.pressure),
            r.map_or(String::new(), |r| num(r.pressure)),
            num(p.tension),
            r.map_or(String::new(), |r| num(r.tension)),
            p.class.clone(),
            p.converged.to_string(),
            p.stopped_by.clone(),
            p.iterations.to_string(),
            p.remesh_events.to_string(),
            num(p.wall_time_s),
        ];
        out.push_str(&row.join(","));
        out.push('\n');
    }
    out
}

/// `diagram.md`: the table, the crossings and the wall time.
pub fn markdown(s: &DiagramSummary) -> String {
    let mut out = format!(
        "# Shape diagram `{}`\n\nE_b/8πκ against the reduced volume v; the continuum is the \
         axisymmetric solver's (Richardson-extrapolated) on the same branch. Δp in κ/R0³, σ in \
         κ/R0², R0 = √(A/4π).\n\n\
         | mesh | branch | v | vertices | E_b/8πκ | continuum | error | Δp (continuum) | \
         σ (continuum) | shape | iterations | stopped by | s |\n\
         |---|---|---:|---:|---:|---:|---:|---|---|---|---:|---|---:|\n",
        s.name
    );
    for p in &s.points {
        if p.status != "completed" {
            out.push_str(&format!(
                "| {} | {} | {} | | {} | | | | | | | | |\n",
                p.mesh, p.branch, p.target, p.status
            ));
            continue;
        }
        let (reference, error, dp, sigma) = match p.reference {
            Some(r) => (
                format!("{:.4}", r.energy),
                p.relative_error
                    .map_or(String::new(), |e| format!("{:+.2} %", 100.0 * e)),
                format!("{:.3} ({:.3})", p.pressure, r.pressure),
                format!("{:.3} ({:.3})", p.tension, r.tension),
            ),
            None => (
                "none".into(),
                String::new(),
                format!("{:.3}", p.pressure),
                format!("{:.3}", p.tension),
            ),
        };
        out.push_str(&format!(
            "| {} | {} | {} | {} | {:.4} | {reference} | {error} | {dp} | {sigma} | {} | {} | {} | {:.2} |\n",
            p.mesh,
            p.branch,
            p.target,
            p.vertices,
            p.energy,
            p.class,
            p.iterations,
            p.stopped_by,
            p.wall_time_s
        ));
    }
    if !s.crossings.is_empty() {
        out.push_str("\n| crossing | on | v | E_b/8πκ |\n|---|---|---:|---:|\n");
        for c in &s.crossings {
            out.push_str(&format!(
                "| {} / {} | {} | {:.4} | {:.4} |\n",
                c.branches.0, c.branches.1, c.mesh, c.reduced_volume, c.energy
            ));
        }
    }
    if !s.extrapolated.is_empty() {
        out.push_str(
            "\nExtrapolated to h → 0 (order 2, from the two finest meshes):\n\n\
             | branch | v | meshes | E_b/8πκ | continuum | error |\n|---|---:|---|---:|---:|---:|\n",
        );
        for e in &s.extrapolated {
            out.push_str(&format!(
                "| {} | {} | {}, {} | {:.5} | {} | {} |\n",
                e.branch,
                e.target,
                e.meshes.0,
                e.meshes.1,
                e.energy,
                e.reference.map_or("none".into(), |r| format!("{r:.5}")),
                e.relative_error
                    .map_or(String::new(), |x| format!("{:+.3} %", 100.0 * x))
            ));
        }
    }
    out.push_str(&format!("\nWall time: {:.1} s.\n", s.wall_time_s));
    out
}

/// `diagram.png`: the continuum curves as lines, each mesh's points as
/// markers in its branch's colour.
fn chart(s: &DiagramSummary) -> Vec<u8> {
    use crate::io::plot::{Chart, Legend, Marker, Series};
    let colour = |b: Branch| match b {
        Branch::Prolate => 0,
        Branch::Oblate => 1,
        Branch::Stomatocyte => 2,
    };
    let mut series: Vec<Series> = s
        .curves
        .iter()
        .map(|(b, c)| Series {
            name: format!("{b} (continuum)"),
            points: c.clone(),
            lines: true,
            color: colour(*b),
            ..Default::default()
        })
        .collect();
    let mut meshes: Vec<&str> = s.points.iter().map(|p| p.mesh.as_str()).collect();
    meshes.dedup();
    for (m, mesh) in meshes.iter().enumerate() {
        let mut branches: Vec<(&str, Branch)> = s
            .points
            .iter()
            .filter(|p| p.mesh == *mesh)
            .map(|p| (p.branch.as_str(), p.reference_branch))
            .collect();
        branches.dedup();
        for (b, kind) in branches {
            let points = s
                .points
                .iter()
                .filter(|p| p.mesh == *mesh && p.branch == b && p.status == "completed")
                .map(|p| (p.reduced_volume, p.energy))
                .collect();
            series.push(Series {
                name: format!("{b}, {mesh}"),
                points,
                markers: true,
                marker: if m % 2 == 0 {
                    Marker::Circle
                } else {
                    Marker::Triangle
                },
                color: colour(kind),
                ..Default::default()
            });
        }
    }
    crate::io::plot::chart(&Chart {
        title: format!("Shape diagram: {}", s.name),
        x_label: "reduced volume v".into(),
        y_label: "E_b / 8πκ".into(),
        series,
        legend: Legend::UpperRight,
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(mesh: &str, branch: &str, v: f64, energy: f64, reference: f64) -> DiagramPoint {
        DiagramPoint {
            mesh: mesh.into(),
            branch: branch.into(),
            reference_branch: Branch::Oblate,
            target: v,
            status: "completed".into(),
            vertices: 642,
            reduced_volume: v,
            energy,
            pressure: f64::NAN,
            tension: f64::NAN,
            class: String::new(),
            converged: true,
            stopped_by: "force_residual".into(),
            iterations: 1,
            remesh_events: 0,
            wall_time_s: 0.0,
            reference: Some(ReferenceValue {
                energy: reference,
                error: 0.0,
                pressure: 0.0,
                tension: 0.0,
            }),
            relative_error: None,
        }
    }

    #[test]
    fn crossings_interpolate_between_the_walked_points() {
        // a - b = 0.1 at v = 0.7 and -0.1 at v = 0.6: equal at 0.65.
        let a = [(0.7, 1.0), (0.6, 1.2)];
        let b = [(0.7, 0.9), (0.6, 1.3)];
        let (v, e) = crossing(&a, &b).unwrap();
        assert!((v - 0.65).abs() < 1e-12 && (e - 1.1).abs() < 1e-12);
        assert!(crossing(&a, &[(0.7, 0.0), (0.6, 0.0)]).is_none());
        // No common reduced volumes: nothing to say.
        assert!(crossing(&a, &[(0.5, 1.0)]).is_none());
    }

    #[test]
    fn richardson_uses_the_two_finest_meshes() {
        let mesh = |label: &str, h| DiagramMesh {
            label: label.into(),
            set: Vec::new(),
            h: Some(h),
        };
        let meshes = [mesh("coarse", 2.0), mesh("mid", 1.0), mesh("fine", 0.5)];
        // E(h) = 1 + 0.1 h²: exact after one order-2 step.
        let points = [
            point("coarse", "o", 0.9, 1.4, 1.0),
            point("mid", "o", 0.9, 1.1, 1.0),
            point("fine", "o", 0.9, 1.025, 1.0),
        ];
        let e = extrapolate(&meshes, &points);
        assert_eq!(e.len(), 1);
        assert_eq!(e[0].meshes, ("mid".to_string(), "fine".to_string()));
        assert!((e[0].energy - 1.0).abs() < 1e-12, "{e:?}");
        assert!(e[0].relative_error.unwrap().abs() < 1e-12);
        // One mesh with h: nothing to extrapolate.
        assert!(extrapolate(&meshes[2..], &points).is_empty());
    }
}
