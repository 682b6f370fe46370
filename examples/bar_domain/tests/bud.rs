//! The example scene through the example binary's CLI (`main_with`): the
//! protein patch starts to bud within the first iterations, the coverage is
//! in the frames, and a misspelt parameter is refused with its position.

use std::path::Path;
use std::process::ExitCode;

fn scene() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bud.ron")
}

/// Measured (seed 1): the bud stands 2.6 l̄ out after 3000 iterations and
/// 3.7 l̄ at equilibrium; 2000 iterations must already show well over 1 l̄.
const MIN_EARLY_BUD_HEIGHT: f64 = 1.0;

#[test]
fn the_patch_buds_and_its_coverage_is_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bud");
    let scene = scene();
    let args = [
        "bar_domain".as_ref(),
        "run".as_ref(),
        scene.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--iterations".as_ref(),
        "2000".as_ref(),
        "--frames".as_ref(),
        "2".as_ref(),
        "--quiet".as_ref(),
    ];
    assert_eq!(
        remembrane::cli::main_with_args(bar_domain::registry(), args),
        ExitCode::SUCCESS
    );
    let series = std::fs::read_to_string(out.join("series.csv")).unwrap();
    let mut lines = series.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (first, last) = (&rows[0], rows.last().unwrap());
    assert!(
        first[col("bud_height")].abs() < 0.5,
        "a sphere at the start"
    );
    assert!(
        last[col("bud_height")] > MIN_EARLY_BUD_HEIGHT,
        "bud height {} after 2000 iterations",
        last[col("bud_height")]
    );
    // The patch bends toward C_p = 0.5 /l̄ from the sphere's 2/R ≈ 0.15.
    assert!(last[col("patch_mean_curvature")] > first[col("patch_mean_curvature")] + 0.1);
    // Diffusion and remeshing keep the proteins (Σφ moves only by
    // interpolation at splits and merges).
    let total = |r: &Vec<f64>| r[col("coverage_total")];
    assert!((total(last) - total(first)).abs() < 0.02 * total(first));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let frame = summary["frames"].as_array().unwrap().last().unwrap()["file"]
        .as_str()
        .unwrap()
        .to_string();
    let vtp = std::fs::read_to_string(out.join(frame)).unwrap();
    assert!(vtp.contains("Name=\"coverage\""));
    assert!(
        summary["timings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|t| t["system"] == "protein_diffusion" && t["stage"] == "Diffuse")
    );
}

#[test]
fn a_bad_plugin_parameter_is_refused_with_its_position() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(scene())
        .unwrap()
        .replace("coverage: 1.0)", "coverage: 1.5)");
    let path = dir.path().join("bad.ron");
    std::fs::write(&path, &text).unwrap();
    let err = remembrane::scene::Scene::load_with(&path, &bar_domain::registry())
        .unwrap_err()
        .to_string();
    let line = text
        .lines()
        .position(|l| l.contains("coverage: 1.5"))
        .unwrap()
        + 1;
    assert!(
        err.contains(&format!("bad.ron:{line}:"))
            && err.contains("energy[1].Custom.params.patch")
            && err.contains("[0, 1]"),
        "{err}"
    );
    let args = ["bar_domain".as_ref(), "check".as_ref(), path.as_os_str()];
    assert_eq!(
        remembrane::cli::main_with_args(bar_domain::registry(), args),
        ExitCode::from(2)
    );
}

/// The plugin term takes part in Metropolis edge flips end to end: the
/// fluctuating vesicle with a protein cap (`scenes/fluctuating_patch.ron`)
/// runs 1000 ticks, flips are proposed at the declared rate and taken, and
/// every proposal is counted once.
#[test]
fn the_plugin_term_prices_metropolis_flips_in_a_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("patch");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/fluctuating_patch.ron");
    let args = [
        "bar_domain".as_ref(),
        "run".as_ref(),
        scene.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--iterations".as_ref(),
        "1000".as_ref(),
        "--quiet".as_ref(),
    ];
    assert_eq!(
        remembrane::cli::main_with_args(bar_domain::registry(), args),
        ExitCode::SUCCESS
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let f = &summary["edge_flips"];
    let n = |k: &str| f[k].as_u64().unwrap();
    // 0.01 proposals per edge per tick on 1920 edges: 19.2 per tick.
    assert!((n("proposed") as f64 - 1000.0 * 19.2).abs() < 400.0, "{f}");
    assert!(n("accepted") > 50, "{f}");
    assert!(n("rejected_energy") > 0, "{f}");
    assert_eq!(
        n("proposed"),
        n("accepted") + n("rejected_topology") + n("rejected_geometry") + n("rejected_energy")
    );
}
