//! The command line: exit codes, output, and clean errors (no panics).

use std::path::Path;
use std::process::{Command, Output};

fn remembrane(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_remembrane"))
        .args(args)
        .output()
        .unwrap()
}

fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

#[test]
fn bundled_scenes_check_and_evaluate() {
    for name in ["sphere.ron", "reference.ron", "red_blood_cell.ron"] {
        let out = remembrane(&["check", &scene(name)]);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let out = remembrane(&["energy", &scene(name), "--json"]);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(json["total_energy"].as_f64().unwrap().is_finite());
    }
}

#[test]
fn energy_reports_the_sphere_and_writes_forces() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("f.csv");
    let out = remembrane(&[
        "energy",
        &scene("sphere.ron"),
        "--json",
        "--forces",
        csv.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!((json["energies"][0]["energy"].as_f64().unwrap() - 25.0136).abs() < 1e-3);
    assert_eq!(json["vertices"], 642);
    assert_eq!(json["quality"]["valence_histogram"]["5"], 12);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "vertex,x,y,z,bending_fx,bending_fy,bending_fz,total_fx,total_fy,total_fz"
    );
    assert_eq!(lines.count(), 642);
}

#[test]
fn bad_input_exits_non_zero_with_a_clean_message() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.ron");
    std::fs::write(
        &bad,
        "Scene(\n  membrane: Icosphere(level: 2),\n  energy: [Bending(kappa: -1.0)],\n)",
    )
    .unwrap();
    let missing = dir.path().join("absent.ron");
    for args in [
        vec!["energy", bad.to_str().unwrap()],
        vec!["check", bad.to_str().unwrap()],
        vec!["check", missing.to_str().unwrap()],
    ] {
        let out = remembrane(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: "), "{err}");
        assert!(
            !err.contains("panicked") && !err.contains("backtrace"),
            "{err}"
        );
        assert!(out.stdout.is_empty(), "no partial output on error");
    }
    let out = remembrane(&["energy", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.ron:3:") && err.contains("energy[0].Bending.kappa"),
        "{err}"
    );
}

#[test]
fn forces_file_is_not_written_on_error() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.ron");
    std::fs::write(
        &bad,
        "Scene(membrane: Icosphere(level: 99), energy: [Bending()])",
    )
    .unwrap();
    let csv = dir.path().join("f.csv");
    let out = remembrane(&[
        "energy",
        bad.to_str().unwrap(),
        "--forces",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!csv.exists());
}
