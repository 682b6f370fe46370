//! Conversions between engine data and numpy arrays / Python objects.

use glam::DVec3;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// An N×3 float64 array of `points`.
pub fn vec3_array<'py>(py: Python<'py>, points: &[DVec3]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = points.iter().flat_map(|p| p.to_array()).collect();
    PyArray1::from_vec(py, flat).reshape([points.len(), 3])
}

/// An N×K int64 array of index tuples.
pub fn index_array<'py, const K: usize>(
    py: Python<'py>,
    rows: &[[u32; K]],
) -> PyResult<Bound<'py, PyArray2<i64>>> {
    let flat: Vec<i64> = rows
        .iter()
        .flat_map(|r| r.iter().map(|&i| i64::from(i)))
        .collect();
    PyArray1::from_vec(py, flat).reshape([rows.len(), K])
}

/// Points from an N×3 float64 array; `what` names it in errors.
pub fn points_from(array: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<DVec3>> {
    let shape = array.shape();
    if shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what}: expected an N×3 array, got shape {shape:?}"
        )));
    }
    let view = array.as_array();
    Ok(view
        .rows()
        .into_iter()
        .map(|r| DVec3::new(r[0], r[1], r[2]))
        .collect())
}

/// Triangles from an F×3 integer array, each index below `vertices`.
pub fn faces_from(
    array: &PyReadonlyArray2<'_, i64>,
    vertices: usize,
    what: &str,
) -> PyResult<Vec<[u32; 3]>> {
    let shape = array.shape();
    if shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what}: expected an F×3 array, got shape {shape:?}"
        )));
    }
    let mut faces = Vec::with_capacity(shape[0]);
    for (k, r) in array.as_array().rows().into_iter().enumerate() {
        let mut f = [0u32; 3];
        for c in 0..3 {
            let i = r[c];
            if i < 0 || i as usize >= vertices {
                return Err(PyValueError::new_err(format!(
                    "{what}: face {k} has vertex index {i}, outside 0..{vertices}"
                )));
            }
            f[c] = i as u32;
        }
        faces.push(f);
    }
    Ok(faces)
}

/// A JSON value as the Python object `json.loads` gives.
pub fn json_to_py<'py>(py: Python<'py>, value: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?
        .call_method1("loads", (value.to_string(),))
}

/// A Python value (bool, int, float, str, None, list/tuple, dict with
/// string keys; numpy scalars through `__index__` / `__float__`) as JSON,
/// numbers exactly.
pub fn py_to_json(value: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    use pyo3::types::{PyBool, PyDict, PyFloat, PyList, PyString, PyTuple};
    use serde_json::Value;
    if value.is_none() {
        return Ok(Value::Null);
    }
    if let Ok(b) = value.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if let Ok(s) = value.cast::<PyString>() {
        return Ok(Value::String(s.extract::<String>()?));
    }
    if let Ok(d) = value.cast::<PyDict>() {
        let mut map = serde_json::Map::new();
        for (k, v) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| PyValueError::new_err("dictionary keys must be strings"))?;
            map.insert(key, py_to_json(&v)?);
        }
        return Ok(Value::Object(map));
    }
    if value.cast::<PyList>().is_ok() || value.cast::<PyTuple>().is_ok() {
        let items: PyResult<Vec<Value>> = value.try_iter()?.map(|v| py_to_json(&v?)).collect();
        return Ok(Value::Array(items?));
    }
    if value.cast::<PyFloat>().is_err() {
        if let Ok(i) = value.extract::<i64>() {
            return Ok(Value::from(i));
        }
        if let Ok(u) = value.extract::<u64>() {
            return Ok(Value::from(u));
        }
    }
    if let Ok(x) = value.extract::<f64>() {
        return serde_json::Number::from_f64(x)
            .map(Value::Number)
            .ok_or_else(|| PyValueError::new_err(format!("{x} is not a finite number")));
    }
    Err(PyValueError::new_err(format!(
        "cannot use a {} as a scene value",
        value.get_type().name()?
    )))
}
