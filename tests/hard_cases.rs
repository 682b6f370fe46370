//! Hard cases (`scenes/hard/`): each runs to completion within its stated
//! bounds or stops with a typed error that names the cause and the fix,
//! never writing a bad frame.

use remembrane::error::{FoldCause, SimError};
use remembrane::run::{Progress, RunError, RunOptions, run_scene};
use remembrane::scene::Scene;
use std::path::Path;

mod common;
use common::frame_is_finite;

fn options(out: &Path) -> RunOptions {
    RunOptions {
        out: out.to_owned(),
        overwrite: false,
        seed: None,
        iterations: None,
        frames: None,
        from: None,
        progress: Progress::Quiet,
        check_invariants: false,
    }
}

#[test]
fn thermal_noise_on_the_as_run_vin_stops_naming_the_noise_and_its_fixes() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/hard/thermal_noise.ron");
    let scene = Scene::load(&path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let err = run_scene(&scene, &path, &options(&out), |_| Ok(())).unwrap_err();
    let message = err.to_string();
    println!("{message}");
    let RunError::Stopped {
        source:
            SimError::MeshFolded {
                iteration,
                shortest_edge,
                noise,
                cause,
                ..
            },
        ..
    } = err
    else {
        panic!("expected a fold, got {message}");
    };
    // Measured (seed 1): iteration 2230, a face of edge 0.07 l̄, drift and
    // noise within a factor of two.
    assert!(iteration > 100, "the mesh starts healthy");
    assert!(
        shortest_edge < 0.3,
        "a collapsed face folds: {shortest_edge}"
    );
    assert!(noise > 0.0);
    assert_ne!(cause, FoldCause::Drift, "the noise takes part");
    assert!(message.contains("thermal noise") && message.contains("dynamics.dt_max"));
    assert_eq!(
        RunError::Sim(SimError::AlreadyStarted(String::new())).exit_code(),
        1
    );
    // Every written frame is finite; the summary says how it ended.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "blew_up");
    for f in summary["frames"].as_array().unwrap() {
        assert!(frame_is_finite(&out.join(f["file"].as_str().unwrap())));
    }
    let mesh = remembrane::mesh::io::read_mesh(&out.join("final.ply")).unwrap();
    assert!(remembrane::mesh::check_mesh(&mesh.positions, &mesh.faces, None).is_ok());
}
