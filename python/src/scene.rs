//! `remembrane.Scene`: a parsed, validated scene and its overrides.

use crate::convert::{faces_from, points_from, py_to_json};
use crate::errors::scene_error;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use remembrane::scene::{MembraneSource, Scene};
use std::path::{Path, PathBuf};

/// A scene: the membrane, its energy terms, parameters and control points,
/// as declared in a RON file (see `scenes/reference.ron`).
///
/// Load one with `Scene.load(path, **overrides)` or `Scene.from_str(text)`.
/// Overrides: `seed=`, `iterations=`, `frames=`, and any parameter by its
/// path with `__` between the parts (`dynamics__temperature=0.1`,
/// `energy__Bending__kappa=20`), or with dots in `set={"dynamics.dt_max": 1e-4}`.
/// Every override is validated as in a file; errors raise `SceneError`.
#[pyclass(name = "Scene", module = "remembrane", frozen)]
#[derive(Clone)]
pub struct PyScene {
    /// The scene.
    pub scene: Scene,
    /// The file it came from (relative mesh and state paths resolve from
    /// its folder; error messages name it).
    pub path: PathBuf,
}

impl PyScene {
    /// Applies the overrides of a `load` / `from_str` / `replace` call.
    fn with_overrides(
        mut self,
        py: Python<'_>,
        seed: Option<u64>,
        iterations: Option<u64>,
        frames: Option<u32>,
        set: Option<&Bound<'_, PyDict>>,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        if let Some(s) = seed {
            self.scene.seed = s;
        }
        if let Some(n) = iterations {
            self.scene.dynamics.iterations = n;
        }
        if let Some(f) = frames {
            self.scene.dynamics.frames = f;
        }
        let mut changes: Vec<(String, Bound<'_, PyAny>)> = Vec::new();
        for (k, v) in set.into_iter().flat_map(|d| d.iter()) {
            changes.push((k.extract()?, v));
        }
        for (k, v) in params.into_iter().flat_map(|d| d.iter()) {
            let key: String = k.extract()?;
            changes.push((key.replace("__", "."), v));
        }
        if !changes.is_empty() {
            let changes: Vec<(String, serde_json::Value)> = changes
                .into_iter()
                .map(|(p, v)| Ok((p, py_to_json(&v)?)))
                .collect::<PyResult<_>>()?;
            self.scene =
                remembrane::scene::overrides::set_parameters(&self.scene, &self.path, &changes)
                    .map_err(|e| scene_error(py, &e))?;
        }
        Ok(self)
    }
}

#[pymethods]
impl PyScene {
    /// Reads and validates a scene file, then applies the overrides.
    #[staticmethod]
    #[pyo3(signature = (path, *, seed=None, iterations=None, frames=None, set=None, **params))]
    fn load(
        py: Python<'_>,
        path: PathBuf,
        seed: Option<u64>,
        iterations: Option<u64>,
        frames: Option<u32>,
        set: Option<&Bound<'_, PyDict>>,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let scene = Scene::load(&path).map_err(|e| scene_error(py, &e))?;
        PyScene { scene, path }.with_overrides(py, seed, iterations, frames, set, params)
    }

    /// Parses scene text. `path` names it in errors and is the folder
    /// relative mesh paths resolve from (default: `<string>` in the
    /// working directory).
    #[staticmethod]
    #[pyo3(signature = (text, path=None, *, seed=None, iterations=None, frames=None, set=None, **params))]
    #[allow(clippy::too_many_arguments)]
    fn from_str(
        py: Python<'_>,
        text: &str,
        path: Option<PathBuf>,
        seed: Option<u64>,
        iterations: Option<u64>,
        frames: Option<u32>,
        set: Option<&Bound<'_, PyDict>>,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let path = path.unwrap_or_else(|| PathBuf::from("<string>"));
        let scene = Scene::from_ron_str(text, &path).map_err(|e| scene_error(py, &e))?;
        PyScene { scene, path }.with_overrides(py, seed, iterations, frames, set, params)
    }

    /// A copy with the overrides applied (same keywords as `load`).
    #[pyo3(signature = (*, seed=None, iterations=None, frames=None, set=None, **params))]
    fn replace(
        &self,
        py: Python<'_>,
        seed: Option<u64>,
        iterations: Option<u64>,
        frames: Option<u32>,
        set: Option<&Bound<'_, PyDict>>,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        self.clone()
            .with_overrides(py, seed, iterations, frames, set, params)
    }

    /// A copy whose membrane is the given mesh: `points` (N×3, l̄) and
    /// `faces` (F×3 vertex indices, counter-clockwise seen from outside).
    /// The mesh is checked (closed, manifold, valences) like a mesh file.
    fn with_mesh(
        &self,
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
    ) -> PyResult<Self> {
        let positions = points_from(&points, "points")?;
        let faces = faces_from(&faces, positions.len(), "faces")?;
        let mut scene = self.scene.clone();
        scene.membrane = MembraneSource::Mesh { positions, faces };
        scene
            .initial_mesh(&self.path)
            .map_err(|e| scene_error(py, &e))?;
        Ok(PyScene {
            scene,
            path: self.path.clone(),
        })
    }

    /// The scene as RON text (loads back to an equal scene).
    fn to_ron(&self) -> PyResult<String> {
        self.scene
            .to_ron_string()
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// The scene's name (the file stem when it declares none).
    #[getter]
    pub fn name(&self) -> String {
        remembrane::workflow::run::run_name(&self.scene, &self.path)
    }

    /// The file the scene came from.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// Seed of every random stream.
    #[getter]
    fn seed(&self) -> u64 {
        self.scene.seed
    }

    /// Iterations of a run.
    #[getter]
    fn iterations(&self) -> u64 {
        self.scene.dynamics.iterations
    }

    /// Frames of a run.
    #[getter]
    fn frames(&self) -> u32 {
        self.scene.dynamics.frames
    }

    /// The energy terms' kinds, in declaration order.
    #[getter]
    fn energy_terms(&self) -> Vec<String> {
        self.scene
            .energy
            .iter()
            .map(|t| t.kind().to_string())
            .collect()
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene({:?}, path={:?}, seed={}, iterations={})",
            self.name(),
            display(&self.path),
            self.scene.seed,
            self.scene.dynamics.iterations
        )
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyScene>()
            .is_ok_and(|o| o.get().scene == self.scene)
    }
}

fn display(p: &Path) -> String {
    p.display().to_string()
}
