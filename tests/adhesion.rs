//! Adhesion of a fluid vesicle (`scenes/open/adhesion_fluid.ron` and its
//! refinement ladders): Seifert & Lipowsky's contact condition, the free
//! membrane's curvature at the contact line c = √(2W/κ), measured by the
//! adhesion recorder's `adhesion_contact_curvature` column
//! (src/analysis/contact_curvature.rs), and the adhered area growing with
//! the reduced adhesion W R²/κ.
//!
//! Both tests are ignored (too slow for CI; the fit itself is unit-tested
//! in src/analysis/contact_curvature.rs). The first runs the 642-vertex
//! rung (h = 1) at W R²/κ = 8 and 16: there
//! the contact radius of curvature spans one or two edges, so it checks
//! that the vesicle comes to rest adhered, that the adhered area grows with
//! W, and that the contact curvature is measured, not its value. The
//! second runs both ladders to 10242 vertices (h = 1/4) and checks
//! the 5 % tolerance: `cargo test --release --test adhesion -- --ignored`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod common;

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// W (Ē/l̄²) of `scenes/open/adhesion_fluid.ron`.
const W: f64 = 0.36;

/// The last value of `column` in `dir`'s series.csv.
fn last(dir: &Path, column: &str) -> f64 {
    *common::series_column(dir, column).last().unwrap()
}

/// Runs `path` into `out` and returns its exit code.
fn run(path: &Path, out: &Path, extra: &[&str]) -> ExitCode {
    let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"run", &path, &"--out", &out];
    for a in extra {
        args.push(a);
    }
    args.push(&"--quiet");
    common::cli(&args)
}

#[test]
#[ignore = "slow: did not finish its first of two runs in 9 minutes of the test profile on the shared 2-core VM (release: about 20-40 s a run); cargo test --release --test adhesion -- --ignored"]
fn the_fluid_vesicle_adheres_more_for_a_stronger_adhesion() {
    let dir = tempfile::tempdir().unwrap();
    // κ = 2 (W R²/κ = 8) through a copy of the scene.
    let text = std::fs::read_to_string(scene("open/adhesion_fluid.ron")).unwrap();
    let weak = dir.path().join("weak.ron");
    std::fs::write(
        &weak,
        text.replace("Bending(kappa: 1.0)", "Bending(kappa: 2.0)"),
    )
    .unwrap();
    let mut areas = Vec::new();
    for (name, path) in [("weak", weak), ("strong", scene("open/adhesion_fluid.ron"))] {
        let out = dir.path().join(name);
        assert_eq!(run(&path, &out, &[]), ExitCode::SUCCESS);
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(summary["status"], "completed");
        let area = last(&out, "adhesion_contact_area");
        let curvature = last(&out, "adhesion_contact_curvature");
        // Adhered over more than the contact zone of a sphere touching the
        // plane (a few faces), and a contact line to fit.
        assert!(area > 20.0, "{name}: adhered area {area}");
        assert!(
            curvature.is_finite() && curvature > 0.0,
            "{name}: {curvature}"
        );
        // The wall below the substrate is never reached.
        assert!(last(&out, "wall_min_distance") > 0.0);
        areas.push(area);
    }
    // Measured 111.0 and 117.9 l̄² (v = 0.9 leaves little room to spread:
    // the free cap's area and the volume are held).
    assert!(areas[1] > areas[0] + 3.0, "adhered areas {areas:?}");
}

#[test]
#[ignore = "about 20 minutes, and it fails today (contact curvature +25 % and +59 % at h = 1/4, docs/adhesion.md): cargo test --release --test adhesion -- --ignored"]
fn the_contact_curvature_is_within_5_percent_of_the_contact_condition() {
    let dir = tempfile::tempdir().unwrap();
    let mut areas = Vec::new();
    for (kappa, ladder) in [
        (2.0, "open/adhesion_fluid_w8_l5.ron"),
        (1.0, "open/adhesion_fluid_l5.ron"),
    ] {
        let out = dir.path().join(ladder.replace('/', "_"));
        assert_eq!(run(&scene(ladder), &out, &[]), ExitCode::SUCCESS);
        let fine = out.join("h1_4");
        let measured = last(&fine, "adhesion_contact_curvature");
        let theory = (2.0 * W / kappa).sqrt();
        assert!(
            (measured / theory - 1.0).abs() < 0.05,
            "κ = {kappa}: contact curvature {measured} against √(2W/κ) = {theory}"
        );
        areas.push(last(&fine, "adhesion_contact_area"));
    }
    assert!(areas[1] > areas[0], "adhered areas {areas:?}");
}
