//! Module-level functions: the finite-difference check of a Python term,
//! test meshes, reading frames and meshes, sweeps and collection.

use crate::convert::{faces_from, index_array, json_to_py, points_from, vec3_array};
use crate::errors::simulation_error;
use crate::force_term::{PyForceTerm, TermErrors};
use crate::interrupt::run_detached;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use remembrane::fd::{FdOptions, Stencil, check_force_term};
use remembrane::mesh::SurfaceMesh;
use remembrane::mesh::membrane::Membrane;
use std::path::PathBuf;

type MeshArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>);

fn mesh_arrays<'py>(py: Python<'py>, mesh: &SurfaceMesh) -> PyResult<MeshArrays<'py>> {
    Ok((
        vec3_array(py, &mesh.positions)?,
        index_array(py, &mesh.faces)?,
    ))
}

/// Checks a Python force term's forces against central finite differences
/// of its energy, vertex by vertex, on the mesh (`points` N×3, `faces`
/// F×3). A vertex passes when |F − F_fd| ≤ rel_tol·|F_fd| + abs_floor.
/// Returns a dict: `passed`, `vertices`, `max_rel_error`, `max_abs_error`,
/// `max_force` and `failures` (vertex, analytic, numeric).
#[pyfunction]
#[pyo3(signature = (r#fn, points, faces, *, step=1e-4, rel_tol=1e-6, abs_floor=1e-9, stencil="central4", vertices=None))]
#[allow(clippy::too_many_arguments)]
pub fn check_force<'py>(
    py: Python<'py>,
    r#fn: Py<PyAny>,
    points: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    step: f64,
    rel_tol: f64,
    abs_floor: f64,
    stencil: &str,
    vertices: Option<Vec<usize>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stencil = match stencil {
        "central2" => Stencil::Central2,
        "central4" => Stencil::Central4,
        other => {
            return Err(PyValueError::new_err(format!(
                "stencil must be \"central2\" or \"central4\" (got {other:?})"
            )));
        }
    };
    if !(step.is_finite() && step > 0.0) {
        return Err(PyValueError::new_err(format!(
            "step must be positive (got {step})"
        )));
    }
    let positions = points_from(&points, "points")?;
    let faces = faces_from(&faces, positions.len(), "faces")?;
    if let Some(v) = &vertices
        && let Some(bad) = v.iter().find(|&&i| i >= positions.len())
    {
        return Err(PyValueError::new_err(format!(
            "vertices: {bad} is outside 0..{}",
            positions.len()
        )));
    }
    let mesh = SurfaceMesh { positions, faces };
    remembrane::mesh::check_mesh(&mesh.positions, &mesh.faces, None)
        .map_err(|e| PyValueError::new_err(format!("the mesh is not a closed membrane: {e}")))?;
    let mut membrane = Membrane::from_mesh(&mesh, false).map_err(simulation_error)?;
    let topology = membrane.topology().map_err(simulation_error)?.clone();
    let mut dense = Vec::new();
    membrane.gather_positions(&mut dense);
    let errors = TermErrors::default();
    let mut term = PyForceTerm::new("python".into(), r#fn, errors.clone());
    let options = FdOptions {
        step,
        stencil,
        rel_tol,
        abs_floor,
    };
    let report = check_force_term(
        &mut term,
        &membrane.world,
        &topology,
        &dense,
        &[],
        vertices.as_deref(),
        options,
    );
    if let Some(e) = errors.take() {
        return Err(e);
    }
    let d = PyDict::new(py);
    d.set_item("passed", report.passed())?;
    d.set_item("vertices", report.vertices)?;
    d.set_item("max_rel_error", report.max_rel_error)?;
    d.set_item("max_abs_error", report.max_abs_error)?;
    d.set_item("max_force", report.max_force)?;
    let failures: Vec<(usize, [f64; 3], [f64; 3])> = report
        .failures
        .iter()
        .map(|f| (f.vertex, f.analytic.to_array(), f.numeric.to_array()))
        .collect();
    d.set_item("failures", failures)?;
    Ok(d)
}

/// An icosphere of `level` subdivisions (0..=7; level 3 has 642 vertices)
/// rescaled to mean edge length `edge_length` (l̄): `(points, faces)`.
#[pyfunction]
#[pyo3(signature = (level, edge_length=1.0))]
pub fn icosphere(py: Python<'_>, level: u32, edge_length: f64) -> PyResult<MeshArrays<'_>> {
    check_level(level)?;
    if !(edge_length.is_finite() && edge_length > 0.0) {
        return Err(PyValueError::new_err(format!(
            "edge_length must be positive (got {edge_length})"
        )));
    }
    mesh_arrays(py, &remembrane::mesh::icosphere(level, edge_length))
}

/// The randomly perturbed icosphere the engine's own force tests use
/// (seeded): `(points, faces)`.
#[pyfunction]
#[pyo3(signature = (level=2, seed=1))]
pub fn perturbed_icosphere(py: Python<'_>, level: u32, seed: u64) -> PyResult<MeshArrays<'_>> {
    check_level(level)?;
    mesh_arrays(py, &remembrane::fd::perturbed_icosphere(level, seed))
}

fn check_level(level: u32) -> PyResult<()> {
    if level > remembrane::mesh::MAX_ICOSPHERE_LEVEL {
        return Err(PyValueError::new_err(format!(
            "level must be at most {} (got {level})",
            remembrane::mesh::MAX_ICOSPHERE_LEVEL
        )));
    }
    Ok(())
}

/// Reads a `.ply` or `.obj` mesh, closed or open: `(points, faces)`.
#[pyfunction]
pub fn read_mesh(py: Python<'_>, path: PathBuf) -> PyResult<MeshArrays<'_>> {
    let mesh =
        remembrane::mesh::io::read_mesh(&path).map_err(|e| PyOSError::new_err(e.to_string()))?;
    mesh_arrays(py, &mesh)
}

/// Writes a mesh (`points` N×3, `faces` F×3) to a `.ply` or `.obj` file,
/// after the engine's invariant check: closed or open (boundary loops),
/// consistently oriented, manifold. A mesh that fails it raises
/// `ValueError` with the reason, and nothing is written.
#[pyfunction]
pub fn write_mesh(
    path: PathBuf,
    points: PyReadonlyArray2<'_, f64>,
    faces: PyReadonlyArray2<'_, i64>,
) -> PyResult<()> {
    let positions = points_from(&points, "points")?;
    let faces = faces_from(&faces, positions.len(), "faces")?;
    remembrane::mesh::check_mesh(&positions, &faces, None)
        .map_err(|e| PyValueError::new_err(format!("{}: invalid mesh: {e}", path.display())))?;
    let mesh = SurfaceMesh { positions, faces };
    remembrane::mesh::io::write_mesh(&path, &mesh).map_err(|e| PyOSError::new_err(e.to_string()))
}

/// A flat open disc in the plane z = 0 of `radius` (l̄), rings of a
/// hexagonal lattice with mean edge near `edge_length` (l̄), normal +z, one
/// boundary loop: `(points, faces)` (the scene's `Disc`).
#[pyfunction]
#[pyo3(signature = (radius, edge_length=1.0))]
pub fn disc(py: Python<'_>, radius: f64, edge_length: f64) -> PyResult<MeshArrays<'_>> {
    check_patch("radius", radius, edge_length)?;
    mesh_arrays(py, &remembrane::mesh::disc(radius, edge_length))
}

/// The open cap of a sphere of `sphere_radius` (l̄) centred at the origin
/// within `opening_angle` degrees (0, 90] of its +z pole, normal outward,
/// one boundary loop: `(points, faces)` (the scene's `SphericalCap`).
#[pyfunction]
#[pyo3(signature = (sphere_radius, opening_angle, edge_length=1.0))]
pub fn spherical_cap(
    py: Python<'_>,
    sphere_radius: f64,
    opening_angle: f64,
    edge_length: f64,
) -> PyResult<MeshArrays<'_>> {
    if !remembrane::mesh::patch::valid_cap_angle(opening_angle) {
        return Err(PyValueError::new_err(format!(
            "opening_angle must be in (0, 90] degrees (got {opening_angle})"
        )));
    }
    check_patch(
        "sphere_radius",
        sphere_radius * opening_angle.to_radians(),
        edge_length,
    )?;
    mesh_arrays(
        py,
        &remembrane::mesh::spherical_cap(sphere_radius, opening_angle, edge_length),
    )
}

/// A generated patch's size `length` (l̄, along its surface) and edge:
/// positive, finite, and at most a million vertices.
fn check_patch(name: &str, length: f64, edge_length: f64) -> PyResult<()> {
    for (what, x) in [(name, length), ("edge_length", edge_length)] {
        if !(x.is_finite() && x > 0.0) {
            return Err(PyValueError::new_err(format!(
                "{what} must be positive and finite (got {x})"
            )));
        }
    }
    let n = remembrane::mesh::patch::patch_vertex_count_for(length, edge_length);
    if n > 1_000_000 {
        return Err(PyValueError::new_err(format!(
            "the patch would have {n} vertices (at most 1000000)"
        )));
    }
    Ok(())
}

/// Reads a frame (`frames/frame_NNNNNN.vtp`): `(points, faces,
/// point_data)`, point data a dict of arrays (N or N×3).
#[pyfunction]
pub fn read_vtp(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyTuple>> {
    use vtkio::model::{Attribute, DataSet, ElementType, VertexNumbers};
    let fail = |reason: String| PyOSError::new_err(format!("{}: {reason}", path.display()));
    let vtk = vtkio::Vtk::import(&path).map_err(|e| fail(e.to_string()))?;
    let DataSet::PolyData { pieces, .. } = vtk.data else {
        return Err(fail("not a PolyData file".into()));
    };
    let piece = pieces
        .into_iter()
        .next()
        .ok_or_else(|| fail("no piece".into()))?
        .into_loaded_piece_data(None)
        .map_err(|e| fail(e.to_string()))?;
    let points: Vec<f64> = piece
        .points
        .cast_into()
        .ok_or_else(|| fail("points are not numbers".into()))?;
    if !points.len().is_multiple_of(3) {
        return Err(fail("points are not 3-D".into()));
    }
    let n = points.len() / 3;
    let faces: Vec<i64> = match piece.polys {
        Some(VertexNumbers::XML {
            connectivity,
            offsets,
        }) => {
            let mut start = 0u64;
            for &o in &offsets {
                if o.checked_sub(start) != Some(3) {
                    return Err(fail("a polygon is not a triangle".into()));
                }
                start = o;
            }
            if start != connectivity.len() as u64 {
                return Err(fail("the offsets do not cover the connectivity".into()));
            }
            if let Some(bad) = connectivity.iter().find(|&&i| i >= n as u64) {
                return Err(fail(format!("vertex index {bad} is outside 0..{n}")));
            }
            connectivity.iter().map(|&i| i as i64).collect()
        }
        Some(VertexNumbers::Legacy { .. }) => return Err(fail("legacy polygons".into())),
        None => Vec::new(),
    };
    let data = PyDict::new(py);
    for a in piece.data.point {
        if let Attribute::DataArray(d) = a {
            let components = match d.elem {
                ElementType::Vectors | ElementType::Normals => 3,
                ElementType::Scalars { num_comp, .. } => num_comp as usize,
                _ => 1,
            };
            let values: Vec<f64> = d
                .data
                .cast_into()
                .ok_or_else(|| fail(format!("array {} is not numeric", d.name)))?;
            if components == 0 || values.len() != n * components {
                return Err(fail(format!(
                    "array {} has {} values for {n} points × {components}",
                    d.name,
                    values.len()
                )));
            }
            let array = PyArray1::from_vec(py, values);
            if components == 1 {
                data.set_item(d.name, array)?;
            } else {
                data.set_item(d.name, array.reshape([n, components])?)?;
            }
        }
    }
    let p = PyArray1::from_vec(py, points).reshape([n, 3])?;
    let f = PyArray1::from_vec(py, faces.clone()).reshape([faces.len() / 3, 3])?;
    PyTuple::new(py, [p.into_any(), f.into_any(), data.into_any()])
}

/// Runs a sweep file (`remembrane sweep`): its shared phases, then every
/// condition × grid point × repeat into `out`, `jobs` at a time, skipping
/// phases and runs that finished before. Returns a dict: `total`,
/// `in_shard`, `skipped`, `completed`, `failed`, `phases`.
#[pyfunction]
#[pyo3(signature = (path, out, *, jobs=1, shard=None, iterations=None, quiet=true, phases_only=false))]
#[allow(clippy::too_many_arguments)]
pub fn sweep<'py>(
    py: Python<'py>,
    path: PathBuf,
    out: PathBuf,
    jobs: usize,
    shard: Option<(usize, usize)>,
    iterations: Option<u64>,
    quiet: bool,
    phases_only: bool,
) -> PyResult<Bound<'py, PyAny>> {
    if jobs == 0 {
        return Err(PyValueError::new_err("jobs must be at least 1"));
    }
    if let Some((i, n)) = shard
        && i >= n
    {
        return Err(PyValueError::new_err(format!(
            "shard (I, N) needs I < N (got ({i}, {n}))"
        )));
    }
    let options = remembrane::workflow::sweep::SweepOptions {
        out,
        jobs,
        shard,
        iterations,
        quiet,
        phases_only,
    };
    // The sweep runs on a worker thread while this (main) thread checks for
    // Ctrl-C; the flag it raises stops the sweep's runs.
    let waiter = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| simulation_error(e.to_string()))?;
    let (result, raised) = run_detached(py, Some(&waiter), |stop| {
        remembrane::workflow::sweep::run_sweep_with(&path, &options, stop)
    });
    if let Some(e) = raised {
        return Err(e);
    }
    let report = result.map_err(|e| match e {
        remembrane::workflow::sweep::SweepError::Scene(s) => crate::errors::scene_error(py, &s),
        e @ remembrane::workflow::sweep::SweepError::Phase { .. } => simulation_error(e),
        e => PyValueError::new_err(e.to_string()),
    })?;
    let failed: Vec<(String, String)> = report
        .failed
        .iter()
        .map(|(d, e)| (d.display().to_string(), e.clone()))
        .collect();
    json_to_py(
        py,
        &serde_json::json!({
            "total": report.total,
            "in_shard": report.in_shard,
            "skipped": report.skipped,
            "completed": report.completed,
            "failed": failed,
            "phases": report.phases,
        }),
    )
}

/// Collects a sweep (`remembrane collect`): fits, tables and charts in
/// `dir`. Returns a dict: `expected` (runs in the sweep), `runs` (runs
/// collected) and `missing` (run directories without results).
#[pyfunction]
#[pyo3(signature = (dir, *, x=None, y=None, frames=None, degree=None))]
pub fn collect<'py>(
    py: Python<'py>,
    dir: PathBuf,
    x: Option<String>,
    y: Option<String>,
    frames: Option<usize>,
    degree: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    let mut options = remembrane::workflow::collect::CollectOptions::default();
    if let Some(x) = x {
        options.x = x;
    }
    if let Some(y) = y {
        options.y = y;
    }
    if let Some(f) = frames {
        options.frames = f;
    }
    if let Some(d) = degree {
        options.degree = d;
    }
    let report = remembrane::workflow::collect::collect(&dir, &options)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let missing: Vec<String> = report
        .missing
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    json_to_py(
        py,
        &serde_json::json!({
            "expected": report.expected,
            "runs": report.runs.len(),
            "missing": missing,
        }),
    )
}

/// Reads a run directory's `summary.json` and `series.csv` with the
/// engine's typed reader: raises ValueError naming the file and the field
/// when a field or column is missing, renamed or malformed (what the
/// engine wrote always passes). `series.csv` is optional.
#[pyfunction]
pub fn check_run_dir(dir: PathBuf) -> PyResult<()> {
    remembrane::io::summary::RunSummary::read(&dir)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    if dir.join("series.csv").is_file() {
        remembrane::io::run_dir::Series::read(&dir)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
    }
    Ok(())
}
