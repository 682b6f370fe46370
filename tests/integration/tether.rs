//! The tether experiment's building blocks: saved states between phases,
//! time-based control-point schedules, radius columns in series.csv.

use remembrane::io::state::SavedState;
use remembrane::mesh::components::{ControlPoint, ControlPointIndex};
use remembrane::scene::Scene;
use remembrane::workflow::run::{RunOptions, run_scene};
use std::path::{Path, PathBuf};

use crate::common;
use common::series_column;

fn options(out: &Path, iterations: u64, from: Option<PathBuf>) -> RunOptions {
    RunOptions {
        iterations: Some(iterations),
        frames: Some(2),
        from,
        check_invariants: Some(true),
        ..RunOptions::quiet(out)
    }
}

#[test]
fn a_phase_continues_from_the_saved_state_of_the_previous_one() {
    let dir = tempfile::tempdir().unwrap();
    let initial_path = crate::common::scene("tether_initial.ron");
    let initial = Scene::load(&initial_path).unwrap();
    let first = dir.path().join("initial");
    run_scene(&initial, &initial_path, &options(&first, 400, None), |_| {
        Ok(())
    })
    .unwrap();
    let state = SavedState::read(&first.join("state.json")).unwrap();
    assert_eq!(state.iteration, 400);
    let rho = state.lipid_density.clone().unwrap();
    assert_eq!(rho.len(), state.positions.len());
    // Σρ = 642 is conserved through remeshing and instant equilibration.
    let total: f64 = rho.iter().sum();
    assert!((total - 642.0).abs() < 1e-9, "Σρ = {total}");

    // The pull starts exactly from that mesh and density.
    let pull_path = crate::common::scene("tether_pull.ron");
    let pull = Scene::load(&pull_path).unwrap();
    let mut opts = options(&dir.path().join("pull"), 50, None);
    opts.from = Some(first.join("state.json"));
    let mut sim_pull = None;
    let summary = run_scene(&pull, &pull_path, &opts, |sim| {
        let membrane = sim
            .resource_mut::<remembrane::mesh::membrane::Membrane>()
            .unwrap();
        assert_eq!(membrane.topology().unwrap().vertex_count(), rho.len());
        let mut gathered = Vec::new();
        membrane.gather_lipid(&mut gathered);
        assert_eq!(gathered, rho, "densities are restored vertex by vertex");
        // a0 = A_t / Σρ.
        sim_pull = Some(sim.initial_state("the test").unwrap().lipid_total);
        Ok(())
    })
    .unwrap();
    assert!((sim_pull.unwrap() - 642.0).abs() < 1e-9);
    assert_eq!(summary.iterations, 50);
    let series = remembrane::io::run_dir::Series::read(&dir.path().join("pull")).unwrap();
    for column in [
        "radius_left",
        "radius_left_norm",
        "radius_right",
        "radius_right_norm",
    ] {
        assert!(series.index(column).is_ok(), "{column} missing");
    }
    // 400 iterations are too few for tethers: no plane section has enough
    // points, which is written as NaN (not as a made-up radius).
    let r = series.first("radius_left").unwrap();
    assert!(r.is_nan() || r > 0.0);
}

#[test]
fn a_bad_state_file_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("state.json");
    std::fs::write(
        &state,
        r#"{"format":"remembrane-state-1","scene":"x","seed":1,"iteration":0,"time":0,
            "positions":[[0,0,0],[1,0,0],[0,1,0]],"faces":[[0,1,7]],"lipid_density":null}"#,
    )
    .unwrap();
    let path = crate::common::scene("tether_pull.ron");
    let scene = Scene::load(&path).unwrap();
    let mut opts = options(&dir.path().join("out"), 1, None);
    opts.from = Some(state.clone());
    let err = run_scene(&scene, &path, &opts, |_| Ok(())).unwrap_err();
    let message = err.to_string();
    assert!(message.contains("state.json"), "{message}");
    assert!(message.contains("field `faces`"), "{message}");
    assert_eq!(err.exit_code(), 2);
    assert!(!dir.path().join("out").exists());
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn time_scheduled_moves_follow_simulated_time() {
    // The pull scene moves point 0 by (−0.75, 0.75, 0) at t = 0, 1.25e-4, …
    let path = crate::common::scene("tether_pull.ron");
    let mut scene = Scene::load(&path).unwrap();
    scene.membrane = remembrane::scene::MembraneSource::Icosphere {
        level: 3,
        mean_edge_length: 1.0,
        jitter: 0.0,
    };
    let mut sim = scene.build(&path).unwrap();
    let start = (-14.0, 14.0);
    while sim.clock().time < 3.0 * 1.25e-4 && sim.clock().iteration < 20_000 {
        // The move for the interval that starts at time t is applied at the
        // beginning of the first tick with clock.time ≥ t.
        let due = (sim.clock().time / 1.25e-4).floor() as i64 + 1;
        sim.tick().unwrap();
        let p = sim
            .membrane_mut()
            .world
            .query_mut::<(&ControlPointIndex, &ControlPoint)>()
            .into_iter()
            .find(|(i, _)| i.0 == 0)
            .map(|(_, c)| c.position)
            .unwrap();
        let moves = ((start.0 - p.x) / 0.75).round() as i64;
        assert_eq!(moves, due, "t = {}", sim.clock().time);
        assert!((p.y - (start.1 + 0.75 * moves as f64)).abs() < 1e-9);
    }
    assert!(
        sim.clock().time > 2.0 * 1.25e-4,
        "the test spans several intervals"
    );
}

#[test]
fn a_named_control_point_records_the_force_its_springs_exert() {
    // A capsule under constant tension; the points sit 0.5 l̄ beyond the
    // poles. At iteration 0 the bottom spring's force on the membrane is
    // k Σ_j (c − x_j) over the pole and its ring, computed here from the
    // generated mesh.
    let dir = tempfile::tempdir().unwrap();
    let text = r#"Scene(
        name: "capsule_force",
        membrane: Capsule(radius: 2.0, length: 10.0),
        energy: [
            Bending(kappa: 1.0),
            Tension(sigma: 0.125),
            Springs(stiffness: 3.0),
        ],
        control_points: [
            (position: (0.0, 0.0, -7.5), name: Some("bottom")),
            (position: (0.0, 0.0, 7.5), name: Some("top")),
        ],
        dynamics: (iterations: 10, frames: 2),
    )"#;
    let path = dir.path().join("capsule.ron");
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(&path).unwrap();
    let out = dir.path().join("run");
    run_scene(&scene, &path, &options(&out, 10, None), |_| Ok(())).unwrap();

    let mesh = remembrane::mesh::capsule(2.0, 10.0, 1.0);
    let pole = 0; // the generator's first vertex is the bottom pole
    assert!((mesh.positions[pole].z + 7.0).abs() < 1e-12);
    let mut patch: Vec<u32> = vec![pole as u32];
    for f in &mesh.faces {
        if f.contains(&(pole as u32)) {
            patch.extend(f.iter().filter(|&&v| v != pole as u32));
        }
    }
    patch.sort();
    patch.dedup();
    let c = glam::DVec3::new(0.0, 0.0, -7.5);
    let expected: glam::DVec3 = patch
        .iter()
        .map(|&j| 3.0 * (c - mesh.positions[j as usize]))
        .sum();

    // The first frame, at iteration 0.
    let col = |name: &str| series_column(&out, name)[0];
    assert_eq!(col("iteration"), 0.0);
    for (axis, want) in [("x", expected.x), ("y", expected.y), ("z", expected.z)] {
        let got = col(&format!("force_bottom_{axis}"));
        assert!((got - want).abs() < 1e-9, "{axis}: {got} vs {want}");
    }
    assert!((col("force_bottom") - expected.length()).abs() < 1e-9);
    // Pulling outward, and the top point mirrors the bottom one.
    assert!(expected.z < -1.0);
    assert!((col("force_top_z") + col("force_bottom_z")).abs() < 1e-9);
}
