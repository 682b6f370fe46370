//! Helpers shared by the integration tests.

use glam::DVec3;
use remembrane::io::summary::RunSummary;
use remembrane::mesh::SurfaceMesh;
use std::path::Path;

/// `path` in the repository (relative to its root).
pub fn repo(path: impl AsRef<Path>) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

/// The bundled scene `scenes/<name>`.
pub fn scene(name: &str) -> std::path::PathBuf {
    repo("scenes").join(name)
}

/// Runs the CLI in process, as `remembrane ARGS…` would from a shell,
/// with the built-in plug-ins only; returns its exit code.
/// Arguments may mix strings and paths: `cli(&[&"run", &scene, &"--quiet"])`.
pub fn cli(args: &[&dyn AsRef<std::ffi::OsStr>]) -> std::process::ExitCode {
    let argv = std::iter::once(std::ffi::OsStr::new("remembrane"))
        .chain(args.iter().map(|a| a.as_ref()))
        .collect::<Vec<_>>();
    remembrane::cli::main_with_args(remembrane::scene::registry::PluginRegistry::new(), argv)
}

/// Whether every point and every point-data value of a frame is finite
/// (the arrays are base64 binary: read them, do not grep them).
pub fn frame_is_finite(path: &Path) -> bool {
    use vtkio::model::{Attribute, DataSet};
    let vtk = vtkio::Vtk::import(path).unwrap();
    let DataSet::PolyData { pieces, .. } = vtk.data else {
        return false;
    };
    let piece = pieces[0].load_piece_data(None).unwrap();
    let points: Vec<f64> = piece.points.cast_into().unwrap();
    let arrays_finite = piece.data.point.iter().all(|a| match a {
        Attribute::DataArray(d) => d
            .data
            .cast_into::<f64>()
            .is_some_and(|v| v.iter().all(|x| x.is_finite())),
        Attribute::Field { .. } => true,
    });
    points.iter().all(|x| x.is_finite()) && arrays_finite
}

/// One column of a run's `series.csv`, a value per frame.
pub fn series_column(run_dir: &Path, name: &str) -> Vec<f64> {
    let series = remembrane::io::run_dir::Series::read(run_dir).unwrap_or_else(|e| panic!("{e}"));
    series.column(name).unwrap_or_else(|e| panic!("{e}"))
}

/// Every file under `dir` by relative path; `summary.json` without the
/// fields that measure wall time (and the notes drawn from them).
pub fn run_contents(dir: &Path) -> std::collections::BTreeMap<std::path::PathBuf, Vec<u8>> {
    let mut out = std::collections::BTreeMap::new();
    for path in files_under(dir) {
        let mut bytes = std::fs::read(&path).unwrap();
        if path.file_name().is_some_and(|n| n == "summary.json") {
            let mut v: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
            let map = v.as_object_mut().unwrap();
            map.remove("timings");
            map.remove("wall_time_s");
            map.remove("time_notes");
            bytes = serde_json::to_vec(&v).unwrap();
        }
        out.insert(path.strip_prefix(dir).unwrap().to_path_buf(), bytes);
    }
    out
}

/// Every file under `dir`, in its subfolders too.
pub fn files_under(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                files.push(path);
            }
        }
    }
    files
}

/// The closest distance between two vertices that are not 1-ring
/// neighbours in a run's final mesh (l̄).
pub fn closest_non_neighbours(out: &Path) -> f64 {
    let mesh = remembrane::mesh::io::read_mesh(&out.join("final.ply")).unwrap();
    let mut m = remembrane::mesh::membrane::Membrane::from_mesh(&mesh, false).unwrap();
    let t = m.topology().unwrap().clone();
    let mut closest = f64::INFINITY;
    for i in 0..mesh.positions.len() {
        for j in i + 1..mesh.positions.len() {
            if !t.neighbours(i).contains(&(j as u32)) {
                closest = closest.min(mesh.positions[i].distance(mesh.positions[j]));
            }
        }
    }
    closest
}

/// The energy of term `term` in a run's `summary.json` (Ē).
pub fn term_energy(summary: &RunSummary, term: &str) -> f64 {
    summary
        .last
        .energies
        .iter()
        .find(|e| e.term == term)
        .unwrap_or_else(|| panic!("no term {term} in the summary"))
        .energy
}

/// The typed `summary.json` of the run in `dir` (a renamed or missing field
/// fails here, naming the file and the field).
pub fn summary(dir: &Path) -> RunSummary {
    RunSummary::read(dir).unwrap_or_else(|e| panic!("{e}"))
}

/// The total lipid density Σρ of a membrane, summed in sorted order (the
/// same bits whatever order the world lists its vertices in).
pub fn total_density(m: &remembrane::mesh::membrane::Membrane) -> f64 {
    let mut v: Vec<f64> = m
        .world
        .query::<&remembrane::mesh::components::LipidDensity>()
        .iter()
        .map(|d| d.0)
        .collect();
    v.sort_by(f64::total_cmp);
    v.iter().sum()
}

/// Runs the `remembrane` binary's `run` on `scene` into `out`, quietly,
/// and asserts it succeeds (its stderr is the failure message).
pub fn run_binary(scene: &Path, out: &Path) {
    let done = std::process::Command::new(env!("CARGO_BIN_EXE_remembrane"))
        .arg("run")
        .arg(scene)
        .args(["--quiet", "--out"])
        .arg(out)
        .output()
        .unwrap();
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
}

/// A closed torus (χ = 0): `n` × `m` grid of quads, two triangles each.
pub fn torus(n: u32, m: u32) -> SurfaceMesh {
    let (big, small) = (3.0, 1.0);
    let mut positions = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (u, v) = (
                i as f64 / n as f64 * std::f64::consts::TAU,
                j as f64 / m as f64 * std::f64::consts::TAU,
            );
            positions.push(DVec3::new(
                (big + small * v.cos()) * u.cos(),
                (big + small * v.cos()) * u.sin(),
                small * v.sin(),
            ));
        }
    }
    let id = |i: u32, j: u32| (i % n) * m + (j % m);
    let mut faces = Vec::new();
    for i in 0..n {
        for j in 0..m {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    SurfaceMesh { positions, faces }
}
