//! Python exceptions of the engine's errors.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use remembrane::scene::SceneError as RustSceneError;

pyo3::create_exception!(
    remembrane,
    SceneError,
    PyValueError,
    "A scene that cannot be loaded: attributes `file`, `line`, `col` (None when the error has no position), `field` and `reason`."
);
pyo3::create_exception!(
    remembrane,
    SimulationError,
    PyRuntimeError,
    "A simulation that stopped: a numerical blow-up (non-finite value, folded face, inside-out membrane), a failed output, or a call that does not fit the simulation's state."
);

/// A `SceneError` with its file, line, column, field and reason attributes.
pub fn scene_error(py: Python<'_>, e: &RustSceneError) -> PyErr {
    let (file, line, col, field, reason) = match e {
        RustSceneError::Read { path, source } => (path, None, None, None, source.to_string()),
        RustSceneError::Parse {
            path,
            line,
            col,
            field,
            reason,
        } => (path, Some(*line), Some(*col), field.clone(), reason.clone()),
        RustSceneError::Invalid {
            path,
            field,
            reason,
        } => (path, None, None, Some(field.clone()), reason.clone()),
        RustSceneError::MeshFile { path, source } => (
            path,
            None,
            None,
            Some("membrane".to_string()),
            source.to_string(),
        ),
        RustSceneError::Mesh {
            path,
            field,
            source,
        } => (
            path,
            None,
            None,
            Some(field.to_string()),
            source.to_string(),
        ),
    };
    let err = SceneError::new_err(e.to_string());
    let value = err.value(py);
    let set = |name: &str, v: Bound<'_, PyAny>| {
        let _ = value.setattr(name, v);
    };
    set(
        "file",
        file.display()
            .to_string()
            .into_pyobject(py)
            .unwrap()
            .into_any(),
    );
    set("line", line.into_pyobject(py).unwrap().into_any());
    set("col", col.into_pyobject(py).unwrap().into_any());
    set("field", field.into_pyobject(py).unwrap().into_any());
    set("reason", reason.into_pyobject(py).unwrap().into_any());
    err
}

/// A `SimulationError` with the engine's message.
pub fn simulation_error(message: impl std::fmt::Display) -> PyErr {
    SimulationError::new_err(message.to_string())
}
