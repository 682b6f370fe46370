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

use crate::analysis::axisymmetric::{self, Branch};
use crate::io::summary::RunSummary;
use crate::scene::setting::{FieldError, Setting};
use crate::scene::{Scene, SceneError};
use crate::workflow::run::{RunOptions, run_scene};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

mod report;
mod run;

pub use report::*;
pub use run::*;

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
        let err = |reason: String| file_error(path, reason);
        let text = std::fs::read_to_string(path).map_err(|e| err(format!("cannot read: {e}")))?;
        let diagram: ShapeDiagram = crate::scene::setting::ron_options()
            .from_str(&text)
            .map_err(|e| {
                err(format!(
                    "{}:{}: {}",
                    e.span.start.line, e.span.start.col, e.code
                ))
            })?;
        diagram.check_fields().map_err(|e| err(e.to_string()))?;
        let walks = diagram.walks(path)?;
        Ok(LoadedDiagram {
            path: path.to_owned(),
            diagram,
            walks,
        })
    }

    /// Checks the fields by themselves: the reduced volumes, at least one
    /// branch and one mesh, plain and unique names, and branches naming
    /// only declared meshes.
    fn check_fields(&self) -> Result<(), FieldError> {
        check_volumes("reduced_volumes", &self.reduced_volumes)?;
        if self.branches.is_empty() {
            return Err(FieldError::new("branches", "give at least one"));
        }
        if self.meshes.is_empty() {
            return Err(FieldError::new("meshes", "give at least one"));
        }
        for (field, names) in [
            (
                "branches",
                self.branches.iter().map(|b| &b.name).collect::<Vec<_>>(),
            ),
            ("meshes", self.meshes.iter().map(|m| &m.label).collect()),
        ] {
            for (i, n) in names.iter().enumerate() {
                if !crate::scene::setting::valid_name(n) {
                    return Err(FieldError::new(
                        format!("{field}[{i}]"),
                        format!("`{n}` must be a plain directory name"),
                    ));
                }
                if names[..i].contains(n) {
                    return Err(FieldError::new(
                        format!("{field}[{i}]"),
                        format!("`{n}` is used twice"),
                    ));
                }
            }
        }
        for (i, branch) in self.branches.iter().enumerate() {
            if let Some(labels) = &branch.meshes
                && let Some(l) = labels
                    .iter()
                    .find(|l| !self.meshes.iter().any(|m| &&m.label == l))
            {
                return Err(FieldError::new(
                    format!("branches[{i}].meshes"),
                    format!("no mesh `{l}` in field `meshes`"),
                ));
            }
        }
        Ok(())
    }

    /// Every walk of the diagram in file `path`, mesh by mesh; fails if a
    /// change of a mesh applies to none of the branches walked on it.
    fn walks(&self, path: &Path) -> Result<Vec<Walk>, DiagramError> {
        let base = path.parent().unwrap_or(Path::new("."));
        let mut walks = Vec::new();
        // Which of each mesh's changes some branch took (one naming a
        // membrane kind applies only to scenes of that kind).
        let mut applied: Vec<Vec<bool>> = self
            .meshes
            .iter()
            .map(|m| vec![false; m.set.len()])
            .collect();
        for (m, mesh) in self.meshes.iter().enumerate() {
            for (i, branch) in self.branches.iter().enumerate() {
                if branch
                    .meshes
                    .as_ref()
                    .is_some_and(|m| !m.contains(&mesh.label))
                {
                    continue;
                }
                walks.push(self.walk(path, base, i, branch, mesh, &mut applied[m])?);
            }
        }
        for (m, mesh) in self.meshes.iter().enumerate() {
            if let Some(k) = applied[m].iter().position(|a| !a) {
                return Err(file_error(
                    path,
                    format!(
                        "field `meshes[{m}].set[{k}]`: `{}` names a membrane that no branch \
                         walked on mesh `{}` starts from",
                        mesh.set[k].0, mesh.label
                    ),
                ));
            }
        }
        Ok(walks)
    }

    /// The walk of branch `i` on `mesh` (scenes relative to `base`, messages
    /// naming `path`), noting in `applied` which of the mesh's changes the
    /// branch's scene took.
    fn walk(
        &self,
        path: &Path,
        base: &Path,
        i: usize,
        branch: &DiagramBranch,
        mesh: &DiagramMesh,
        applied: &mut [bool],
    ) -> Result<Walk, DiagramError> {
        let err = |reason: String| file_error(path, reason);
        let volumes = branch
            .reduced_volumes
            .as_deref()
            .unwrap_or(&self.reduced_volumes);
        check_volumes(&format!("branches[{i}].reduced_volumes"), volumes)
            .map_err(|e| err(e.to_string()))?;
        let scene_path = base.join(&branch.scene);
        let scene = Scene::load(&scene_path)?;
        let changes = changes_for(&mesh.set, &scene);
        for (k, (changed, _)) in mesh.set.iter().enumerate() {
            if changes.iter().any(|(p, _)| p == changed) {
                applied[k] = true;
            }
        }
        let scene = crate::scene::overrides::set_parameters(&scene, &scene_path, &changes)?;
        scene
            .refuse_ladder("a point of the diagram")
            .map_err(|r| err(format!("field `branches[{i}].scene`: {r}")))?;
        if !matches!(scene.dynamics.method, crate::params::Method::Minimise(_)) {
            return Err(err(format!(
                "field `branches[{i}].scene`: {} does not minimise (a shape diagram holds \
                 equilibrium shapes: give `dynamics.method: Minimise(...)`)",
                scene_path.display()
            )));
        }
        if scene.bending_kappa().is_none() {
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
        Ok(Walk {
            mesh: mesh.label.clone(),
            branch: branch.name.clone(),
            reference: branch.reference,
            scene_path,
            points,
        })
    }
}

/// The error of a diagram file `path` that is invalid for `reason`.
fn file_error(path: &Path, reason: String) -> DiagramError {
    DiagramError::File {
        path: path.to_owned(),
        reason,
    }
}

/// Checks the reduced volumes of `field`: at least one, each in (0, 1).
fn check_volumes(field: &str, vs: &[f64]) -> Result<(), FieldError> {
    if vs.is_empty() {
        return Err(FieldError::new(field, "give at least one"));
    }
    match vs
        .iter()
        .find(|v| !(v.is_finite() && **v > 0.0 && **v < 1.0))
    {
        Some(v) => Err(FieldError::new(
            field,
            format!("a reduced volume must be in (0, 1) (got {v})"),
        )),
        None => Ok(()),
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
