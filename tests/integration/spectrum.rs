//! The flicker-spectrum projection: a synthetic mesh with prescribed
//! harmonics gives them back, and the Helfrich fit recovers κ and σ from a
//! spectrum generated with them.

use crate::common;

use glam::DVec3;
use remembrane::analysis::spectrum::{
    discrete_mode_stiffness, fit, helfrich_power, lm_index, power_by_l, project, real_harmonics,
};
use remembrane::mesh::icosphere;

/// Largest error of a recovered u_lm, relative to the largest prescribed
/// amplitude (issue 15: 1e-3).
const RECOVERY_TOLERANCE: f64 = 1e-3;

/// A level-`level` icosphere of radius `r` whose vertex radii follow
/// r (1 + Σ a_lm Y_lm).
fn shaped(level: u32, r: f64, amplitudes: &[(usize, i64, f64)], l_max: usize) -> Vec<DVec3> {
    let mesh = icosphere(level, 1.0);
    let mut y = Vec::new();
    mesh.positions
        .iter()
        .map(|p| {
            let d = p.normalize();
            real_harmonics(l_max, d, &mut y);
            let u: f64 = amplitudes
                .iter()
                .map(|&(l, m, a)| a * y[lm_index(l, m)])
                .sum();
            d * r * (1.0 + u)
        })
        .collect()
}

#[test]
fn a_mesh_with_prescribed_harmonics_gives_them_back() {
    let l_max = 8;
    let amplitudes = [
        (2, 0, 0.02),
        (2, -1, -0.01),
        (3, 2, 0.012),
        (5, -4, 0.006),
        (7, 3, 0.004),
    ];
    let mesh = icosphere(6, 1.0);
    let positions = shaped(6, 12.0, &amplitudes, l_max);
    let shape = project(&positions, &mesh.faces, l_max);
    let biggest = 0.02;
    let mut worst: (f64, usize, i64) = (0.0, 0, 0);
    for l in 2..=l_max {
        for m in -(l as i64)..=l as i64 {
            let want = amplitudes
                .iter()
                .find(|a| a.0 == l && a.1 == m)
                .map_or(0.0, |a| a.2);
            let got = shape.modes[lm_index(l, m)];
            let err = (got - want).abs() / biggest;
            if err > worst.0 {
                worst = (err, l, m);
            }
        }
    }
    println!(
        "R0 = {:.6} (12), worst error {:.2e} of the largest amplitude at (l, m) = ({}, {})",
        shape.mean_radius, worst.0, worst.1, worst.2
    );
    assert!(worst.0 < RECOVERY_TOLERANCE, "{worst:?}");
    assert!((shape.mean_radius - 12.0).abs() < 1e-3 * 12.0);
}

#[test]
fn the_harmonics_are_orthonormal_under_the_face_quadrature() {
    // A sphere shaped by one harmonic at a time: the projection is that
    // harmonic's unit vector (the Gram matrix of the rule, to first order),
    // within the linear interpolation's O((l h)²): on a level-6 mesh
    // (40962 vertices) within 1e-3 of the amplitude for l ≤ 6.
    let tolerance = 1e-3;
    let l_max = 6;
    let mesh = icosphere(6, 1.0);
    let mut worst = 0.0f64;
    for (l, m) in [(2, 0), (3, -3), (4, 2), (6, 5)] {
        let positions = shaped(6, 1.0, &[(l, m, 1e-4)], l_max);
        let shape = project(&positions, &mesh.faces, l_max);
        for (k, u) in shape.modes.iter().enumerate().skip(4) {
            let want = if k == lm_index(l, m) { 1e-4 } else { 0.0 };
            worst = worst.max((u - want).abs() / 1e-4);
        }
    }
    println!("worst deviation from the unit vectors: {worst:.2e}");
    assert!(worst < tolerance, "{worst:e}");
}

#[test]
fn the_fit_recovers_kappa_and_sigma_from_a_helfrich_spectrum() {
    // Frames whose powers scatter by a few percent around Helfrich's
    // spectrum for κ = 1.5 Ē, σ = 0.01 Ē/l̄² at R0 = 13 l̄, k_BT = 0.1 Ē.
    let (kbt, kappa, sigma, r) = (0.1, 1.5, 0.01, 13.0);
    let l_max = 10;
    let frames: Vec<(f64, Vec<f64>)> = (0..200)
        .map(|f| {
            let wobble = 1.0 + 0.05 * ((f as f64) * 0.7).sin();
            let p = (0..=l_max)
                .map(|l| {
                    if l < 2 {
                        0.0
                    } else {
                        helfrich_power(l, kbt, kappa, sigma, r)
                            * (wobble + 0.02 * ((f * l) as f64).cos())
                    }
                })
                .collect();
            (r, p)
        })
        .collect();
    let s = fit(&frames, 10, 2, l_max, kbt).unwrap();
    println!(
        "κ = {:.4} ± {:.4}, σ = {:.5} ± {:.5}, χ²/dof {:.2}",
        s.kappa, s.kappa_error, s.sigma, s.sigma_error, s.chi2_per_dof
    );
    assert!((s.kappa / kappa - 1.0).abs() < 0.02);
    assert!((s.sigma - sigma).abs() < 0.2 * sigma);
    assert!(s.kappa_error > 0.0 && s.kappa_error < 0.1 * kappa);
    // power_by_l averages u_lm² over m.
    let modes: Vec<f64> = (0..9).map(|k| k as f64).collect();
    assert_eq!(
        power_by_l(&modes, 2),
        [
            0.0,
            (1.0 + 4.0 + 9.0) / 3.0,
            (16.0 + 25.0 + 36.0 + 49.0 + 64.0) / 5.0
        ]
    );
}

#[test]
fn the_spectrum_command_analyses_a_run_directory_and_refuses_other_input() {
    use std::process::ExitCode;
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("noisy.ron");
    std::fs::write(
        &scene,
        r#"Scene(
    membrane: Icosphere(level: 2),
    energy: [Vin(v0: 2.0), Bending(kappa: 1.5), Area(k: 2.0, target: OfInitial(1.0))],
    dynamics: (mobility: 1000.0, temperature: 0.1, dt_max: 1e-5, iterations: 400, frames: 20),
    remesh: (mode: FreeEnergy),
)"#,
    )
    .unwrap();
    let out = dir.path().join("run");
    assert_eq!(
        common::cli(&[&"run", &scene, &"--out", &out, &"--quiet"]),
        ExitCode::SUCCESS
    );
    let spectrum: [&dyn AsRef<std::ffi::OsStr>; 6] =
        [&"spectrum", &out, &"--blocks", &"4", &"--l-max", &"6"];
    assert_eq!(common::cli(&spectrum), ExitCode::SUCCESS);
    let csv = std::fs::read_to_string(out.join("spectrum.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 5, "l = 2..=6");
    // Against the discrete energy's own mode stiffness: recorded per l.
    let discrete: [&dyn AsRef<std::ffi::OsStr>; 7] = [
        &"spectrum",
        &out,
        &"--blocks",
        &"4",
        &"--l-max",
        &"6",
        &"--discrete",
    ];
    assert_eq!(common::cli(&discrete), ExitCode::SUCCESS);
    let fit_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("spectrum_fit.json")).unwrap())
            .unwrap();
    let stiffness = fit_json["stiffness"].as_array().unwrap();
    assert_eq!(stiffness.len(), 7, "index l = 0..=6");
    // A 162-vertex vesicle: modes of a few edges are much softer.
    let s6 = stiffness[6].as_f64().unwrap();
    assert!(s6 > 0.2 && s6 < 0.9, "{s6}");
    // The continuum fit again, for what follows.
    assert_eq!(common::cli(&spectrum), ExitCode::SUCCESS);
    let fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("spectrum_fit.json")).unwrap())
            .unwrap();
    assert_eq!(fit["kbt"], 0.1, "k_BT from the run's scene");
    assert!(fit["kappa"].as_f64().unwrap().is_finite());
    assert!(out.join("spectrum.png").exists());
    // Not a run directory; more blocks than frames.
    assert_eq!(common::cli(&[&"spectrum", &dir.path()]), ExitCode::from(2));
    assert_eq!(
        common::cli(&[&"spectrum", &out, &"--blocks", &"100"]),
        ExitCode::from(2)
    );
}

/// The bundled tethered vesicle (`scenes/fluctuating/tethered.ron`, 642
/// vertices at 300 K, no triangulation change) against the continuum
/// Helfrich spectrum of its input κ with σ = 0, l by l. Its noise, forces
/// and spectrum analysis together put l = 7, 8 at 0.89 ± 0.04 and
/// 0.92 ± 0.03 of it: the discrete bending energy alone would give 1.20 and
/// 1.25 there (it is 0.835 and 0.80 as stiff as the continuum; see
/// `the_discrete_bending_energy_softens_short_modes_as_measured`), and V_in's
/// stretching stiffens them back. A wrong noise strength or κ would move
/// them by its factor. The stretching must stiffen the low modes (l = 2:
/// 0.06), and the five-fold vertices buckle into an icosahedral facetting
/// (l = 6: 11×).
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_tethered_vesicle_fluctuates_with_the_input_kappa_in_its_bending_modes() {
    use remembrane::io::spectrum::{SpectrumOptions, analyse_run};
    let scene = crate::common::repo("scenes/fluctuating/tethered.ron");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let run = [
        "remembrane".as_ref(),
        "run".as_ref(),
        scene.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--quiet".as_ref(),
    ];
    assert_eq!(
        remembrane::cli::main_with_args(remembrane::scene::registry::PluginRegistry::new(), run),
        std::process::ExitCode::SUCCESS
    );
    let (kbt, kappa) = (0.1, 1.5);
    let options = SpectrumOptions {
        equilibration: 0.05,
        l_min: 2,
        l_max: 8,
        blocks: 10,
        kbt,
        kappa_input: Some(kappa),
        discrete: false,
    };
    let s = analyse_run(&out, &options).unwrap();
    let ratio = |l: usize| {
        let helfrich = helfrich_power(l, kbt, kappa, 0.0, s.mean_radius);
        (s.power[l] / helfrich, s.power_error[l] / helfrich)
    };
    for l in [7, 8] {
        let (r, e) = ratio(l);
        // Within 4 error bars of the measured 0.85-1.0.
        assert!(
            r > 0.85 - 4.0 * e && r < 1.0 + 4.0 * e,
            "l = {l}: {r} ± {e}"
        );
    }
    assert!(ratio(2).0 < 0.3, "l = 2 not stiffened: {:?}", ratio(2));
    assert!(ratio(6).0 > 3.0, "no icosahedral facetting: {:?}", ratio(6));
}

/// The bundled fluid vesicle with Metropolis edge flips
/// (`scenes/fluctuating/flips.ron`, 642 vertices at 300 K), sampled in
/// memory every 2 ms after 0.05 s (the invariant check after each flip is
/// off here: `tests/integration/edge_flips.rs` runs it): its fitted κ is the input κ
/// within the discretization's measured 10-15 % (1.28 ± 0.09 Ē for 1.5 Ē;
/// 1.37 ± 0.03 Ē at 2562 vertices). Split/merge remeshing in its place gives
/// 1.02 ± 0.03 Ē (`scenes/fluctuating/fluid.ron`), below this test's bound:
/// those events are not detailed-balanced moves.
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_vesicle_fluid_by_metropolis_flips_fluctuates_with_the_input_kappa() {
    use remembrane::engine::simulation::{CheckInvariants, Clock, DensePositions};
    let path = crate::common::repo("scenes/fluctuating/flips.ron");
    let scene = remembrane::scene::Scene::load(&path).unwrap();
    let mut sim = scene.build(&path).unwrap();
    sim.resource_mut::<CheckInvariants>().0 = false;
    let (l_max, sample_every) = (8, 0.002);
    let mut frames = Vec::new();
    let mut next = 0.05;
    while sim.resource::<Clock>().time < 0.2 {
        sim.tick().unwrap();
        if sim.resource::<Clock>().time >= next {
            next += sample_every;
            let faces = sim.membrane().cached_topology().faces.clone();
            let shape = project(&sim.resource::<DensePositions>().0, &faces, l_max);
            frames.push((shape.mean_radius, power_by_l(&shape.modes, l_max)));
        }
    }
    let s = fit(&frames, 10, 2, l_max, 0.1).unwrap();
    let ratio = s.kappa / 1.5;
    assert!(
        ratio > 0.75 && ratio < 1.1,
        "κ = {} ± {} Ē against 1.5",
        s.kappa,
        s.kappa_error
    );
    assert!(s.kappa_error < 0.15, "κ error bar {}", s.kappa_error);
}

/// The discrete Helfrich energy is softer than the continuum against short
/// shape modes, by a factor set by the mode's wavelength over the edge
/// length: on a 2562-vertex sphere (R = 13.2 l̄) 0.986, 0.956 and 0.856 of
/// the continuum at l = 3, 7 and 14; on a 642-vertex one (R = 6.6 l̄) 0.835
/// at l = 7. Thermal amplitudes are larger by the inverse, which is most of
/// what the flicker fit reads as a lower κ (docs/thermal.md). A
/// disordered triangulation of the same sphere (tangential jitter 0.3)
/// softens the same way, within 0.01.
#[test]
fn the_discrete_bending_energy_softens_short_modes_as_measured() {
    use remembrane::mesh::ellipsoid;
    let regular = icosphere(4, 1.0);
    let jittered = ellipsoid(4, [13.0, 13.0, 13.0], 0.3, 5);
    for (l, expected) in [(3, 0.986), (7, 0.956), (14, 0.856)] {
        let s = discrete_mode_stiffness(&regular.positions, &regular.faces, l);
        assert!((s - expected).abs() < 0.005, "l = {l}: {s}");
        let j = discrete_mode_stiffness(&jittered.positions, &jittered.faces, l);
        assert!((j - s).abs() < 0.01, "l = {l}: jittered {j}, regular {s}");
    }
    let small_mesh = icosphere(3, 1.0);
    let small = discrete_mode_stiffness(&small_mesh.positions, &small_mesh.faces, 7);
    assert!(
        (small - 0.835).abs() < 0.005,
        "642 vertices, l = 7: {small}"
    );
}
