//! Hard cases (`scenes/hard/`): each runs to completion within its stated
//! bounds or stops with a typed error that names the cause and the fix,
//! never writing a bad frame.

use remembrane::engine::error::{FoldCause, SimError};
use remembrane::io::summary::{RunStatus, RunSummary};
use remembrane::scene::Scene;
use remembrane::workflow::run::RunOptions;
use remembrane::workflow::run::{RunError, run_scene};
use std::path::{Path, PathBuf};

use crate::common;
use common::{frame_is_finite, series_column};

/// Runs `scenes/hard/NAME.ron` (for `iterations` if given, 3 frames then)
/// into a temporary directory; returns the outcome, the scene and the run
/// directory (alive while the returned `TempDir` is).
fn run_hard(
    name: &str,
    iterations: Option<u64>,
) -> (
    Result<RunSummary, RunError>,
    Scene,
    tempfile::TempDir,
    PathBuf,
) {
    let path = crate::common::repo("scenes/hard").join(format!("{name}.ron"));
    let scene = Scene::load(&path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let mut opts = RunOptions::quiet(&out);
    if iterations.is_some() {
        opts.iterations = iterations;
        opts.frames = Some(3);
    }
    let outcome = run_scene(&scene, &path, &opts, |_| Ok(()));
    (outcome, scene, dir, out)
}

/// The run's summary.json, after checking that every frame it lists is
/// finite and that the final mesh is valid.
fn checked_summary(out: &Path) -> RunSummary {
    let summary = common::summary(out);
    for f in &summary.frames {
        assert!(frame_is_finite(&out.join(&f.file)));
    }
    let mesh = remembrane::mesh::io::read_mesh(&out.join("final.ply")).unwrap();
    assert!(remembrane::mesh::check_mesh(&mesh.positions, &mesh.faces, None).is_ok());
    summary
}

#[test]
fn thermal_noise_on_the_as_run_vin_stops_naming_the_noise_and_its_fixes() {
    let (outcome, _, _dir, out) = run_hard("thermal_noise", None);
    let err = outcome.unwrap_err();
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
        RunError::Sim(SimError::Output(String::new())).exit_code(),
        1
    );
    // Every written frame is finite; the summary says how it ended.
    assert_eq!(checked_summary(&out).status, RunStatus::BlewUp);
}

/// Runs `scenes/hard/NAME.ron` for 3000 iterations; it must complete with
/// every valence in the scene's range, every edge inside the remesh
/// triggers (or the leftover reported as an unresolved tick) and no angle
/// below `MIN_ANGLE_DEG`.
fn completes_healthy(name: &str) -> RunSummary {
    completes_healthy_in(name).0
}

/// [`completes_healthy`], also returning the run directory (and the
/// temporary directory that holds it).
fn completes_healthy_in(name: &str) -> (RunSummary, tempfile::TempDir, PathBuf) {
    let (outcome, scene, dir, out) = run_hard(name, Some(3000));
    assert!(outcome.is_ok(), "{name}: {}", outcome.err().unwrap());
    let s = checked_summary(&out);
    let q = &s.last.quality;
    println!("{name}: {q:?}");
    let unresolved = s.remesh.unresolved_ticks;
    let (lo, hi) = (scene.remesh.shorter_than, scene.remesh.longer_than);
    assert!(
        unresolved > 0 || (q.edge_min >= lo && q.edge_max <= hi),
        "{name}: an edge left outside [{lo}, {hi}] unreported"
    );
    assert!(q.min_angle_deg > MIN_ANGLE_DEG, "{name}");
    for &valence in q.valence_histogram.keys() {
        let v = valence as u32;
        assert!(
            (scene.valence.min..=scene.valence.max).contains(&v),
            "{name}: valence {v}"
        );
    }
    (s, dir, out)
}

/// The smallest angle a completed hard case may leave (degrees; measured
/// 37-47° in the three cases below).
const MIN_ANGLE_DEG: f64 = 20.0;

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn control_points_100_times_stiffer_than_as_run_complete_with_a_healthy_mesh() {
    let s = completes_healthy("stiff_control_points");
    assert!(s.remesh.split.success > 100, "the pull grows the mesh");
}

#[test]
fn a_one_second_step_cap_at_mobility_ten_thousand_completes_with_a_healthy_mesh() {
    completes_healthy("huge_time_step");
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn valences_limited_to_5_to_7_stay_in_range_through_remeshing() {
    let s = completes_healthy("narrow_valence");
    assert!(s.remesh.merge.success > 50);
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_sudden_deflation_to_v_0_4_completes_with_a_healthy_mesh() {
    let s = completes_healthy("sudden_deflation");
    let v = s.last.reduced_volume.unwrap();
    assert!(v < 0.5, "deflated: v = {v}");
}

#[test]
fn bending_without_a_step_limit_stops_naming_the_drift_and_its_fixes() {
    let (outcome, _, _dir, out) = run_hard("bending_no_cap", None);
    let err = outcome.unwrap_err();
    let message = err.to_string();
    assert!(
        matches!(
            err,
            RunError::Stopped {
                source: SimError::MeshFolded {
                    cause: FoldCause::Drift,
                    noise: 0.0,
                    ..
                },
                ..
            }
        ),
        "{message}"
    );
    assert!(message.contains("dynamics.max_displacement") && message.contains("Vin"));
    assert!(message.contains("dynamics.bending_step_limit"));
    assert_eq!(checked_summary(&out).status, RunStatus::BlewUp);
}

#[test]
fn bending_with_the_stability_bound_relaxes_without_a_cap() {
    let (outcome, _, _dir, out) = run_hard("bending_stable_step", None);
    let summary = outcome.unwrap();
    assert_eq!(summary.iterations, 3000);
    let s = checked_summary(&out);
    assert_eq!(s.status, RunStatus::Completed);
    // The energy never rises (an unstable explicit step makes it grow).
    let series = remembrane::io::run_dir::Series::read(&out).unwrap();
    let (e, dt) = (
        series.index("energy_bending").unwrap(),
        series.index("dt").unwrap(),
    );
    let rows = series.rows;
    for w in rows.windows(2) {
        assert!(
            w[1][e] <= w[0][e] + 1e-12,
            "energy rose: {} -> {}",
            w[0][e],
            w[1][e]
        );
    }
    // It relaxes to the discrete sphere's energy (25.0136 Ē, sphere.ron)
    // at the bound's step, not at a hand-picked one.
    let last = rows.last().unwrap();
    assert!((last[e] - 25.0136).abs() < 1e-3, "{}", last[e]);
    let steps: Vec<f64> = rows[1..].iter().map(|r| r[dt]).collect();
    assert!(steps.iter().all(|&d| d > 2e-5 && d < 6e-5), "{steps:?}");
    assert!(s.last.quality.min_angle_deg > 45.0);
}

#[test]
fn a_thin_tether_pulled_fast_grows_by_splits_and_keeps_its_radius() {
    let (s, _dir, out) = completes_healthy_in("thin_tether_fast_pull");
    assert_eq!(s.remesh.unresolved_ticks, 0);
    // 34 moves of 0.25 l̄ in 0.034 s: the splits keep up with the pull.
    let splits = s.remesh.split.success;
    assert!(splits > 50, "{splits} splits");
    // The tube stays a tube at about its DJP radius (1.1524 l̄) while
    // stretched by 74 %: within 10 % on every frame, no pinch.
    for radius in series_column(&out, "radius_tube") {
        assert!((radius / 1.1524 - 1.0).abs() < 0.1, "radius {radius}");
    }
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn thermal_noise_ten_times_300_k_with_remeshing_keeps_a_valid_mesh() {
    // 150 iterations here (the burst of the first ticks); the scene's
    // header has the 10^5-iteration run.
    let (outcome, scene, _dir, out) = run_hard("thermal_noise_hot", Some(150));
    assert!(outcome.is_ok(), "{}", outcome.err().unwrap());
    let s = checked_summary(&out);
    let q = &s.last.quality;
    assert!(q.min_angle_deg > MIN_ANGLE_DEG, "{q:?}");
    for &valence in q.valence_histogram.keys() {
        let v = valence as u32;
        assert!((scene.valence.min..=scene.valence.max).contains(&v));
    }
    // The noise keeps remeshing busy: over a thousand events in 150 ticks.
    let events = s.remesh.events;
    assert!(events > 1000, "{events} events");
}

/// The lamellipodium's rim (issue 13): with the as-run spring coupling 64
/// ticks of the 2×10^4 ended with an edge left abnormal for the next tick
/// (split pre-relaxations failing against the ring squeeze). The bundled
/// scene now uses the centroid coupling; the whole run leaves none.
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn the_lamellipodium_rim_leaves_no_edge_unresolved() {
    let path = crate::common::repo("scenes/lamellipodium.ron");
    let scene = Scene::load(&path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let mut opts = RunOptions::quiet(&out);
    opts.frames = Some(2);
    let summary = run_scene(&scene, &path, &opts, |_| Ok(())).unwrap();
    println!("{:?}", summary.remesh);
    assert_eq!(summary.iterations, 20_000);
    assert!(summary.remesh.events > 1000, "the rim is remeshed");
    assert_eq!(summary.remesh.unresolved_ticks, 0);
    assert_eq!(summary.remesh.overflow_ticks, 0);
    checked_summary(&out);
}

/// Two membrane regions pressed together (`self_contact.ron`): a spring
/// drags the top of a deflating vesicle through its inside onto the bottom
/// wall. With SelfAvoidance the walls stay about its range apart and the
/// mesh stays healthy; without it they come much closer (the case is hard).
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn walls_pressed_together_stay_apart_with_a_healthy_mesh() {
    let (outcome, _, _dir, out) = run_hard("self_contact", None);
    let summary = outcome.unwrap();
    assert_eq!(summary.iterations, 2600);
    let q = &summary.last.quality;
    assert!(
        q.min_angle_deg > 20.0 && q.edge_min > 0.6 && q.edge_max < 1.4,
        "{q:?}"
    );
    checked_summary(&out);
    let with = common::closest_non_neighbours(&out);

    let path = crate::common::repo("scenes/hard/self_contact.ron");
    let text = std::fs::read_to_string(&path).unwrap();
    let term = "        SelfAvoidance(k: 500.0, distance: 0.6),\n";
    assert!(text.contains(term));
    let scene = Scene::from_ron_str(&text.replace(term, ""), &path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let bare = dir.path().join("run");
    run_scene(&scene, &path, &RunOptions::quiet(&bare), |_| Ok(())).unwrap();
    let without = common::closest_non_neighbours(&bare);
    println!("closest non-neighbours: {with:.3} l̄ with self-avoidance, {without:.3} l̄ without");
    // Measured (seed 1): 0.560 l̄ with, 0.153 l̄ without.
    assert!(with > 0.45, "with self-avoidance: {with}");
    assert!(
        without < 0.3,
        "without self-avoidance the walls meet: {without}"
    );
}
