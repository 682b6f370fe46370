//! The Lévy sampler, the local relaxation, and remeshing runs: after every
//! tick all edges are within the triggers (or an overflow was counted),
//! valences stay in range and Σρ is conserved.

use crate::common;
use rand::SeedableRng;
use remembrane::energy::vin::VinSegmentation;
use remembrane::energy::vin::{Segmentation, VinParams};
use remembrane::engine::force::ForceBuffers;
use remembrane::engine::shared_resources::AbnormalEdges;
use remembrane::remesh::RemeshStats;
use remembrane::remesh::relax::{
    Goal, KickTable, Patch, RelaxOutcome, RelaxSettings, Relaxed, relax, rings, stable_alpha1_beta1,
};
use remembrane::scene::Scene;
use std::f64::consts::PI;

#[test]
fn levy_sampler_matches_the_stable_characteristic_function() {
    // S(α = 1, β = 1, γ = 1, δ = 0) in the S1 parametrisation:
    // E[e^{itX}] = exp(−|t| (1 + i β (2/π) sign(t) ln|t|)).
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(42);
    let n = 400_000;
    let direct: Vec<f64> = (0..n).map(|_| stable_alpha1_beta1(&mut rng)).collect();
    check_stable_sample(&direct);
    // The relaxation's kick table: uniform picks from 2^14 pre-sampled draws.
    let table = KickTable::new(&mut rng);
    assert_eq!(table.draws().len(), KickTable::SIZE);
    let picked: Vec<f64> = (0..n).map(|_| table.draw(&mut rng)).collect();
    check_stable_sample(&picked);
}

fn check_stable_sample(xs: &[f64]) {
    let n = xs.len();
    for t in [0.25f64, 0.5, 1.0, 2.0] {
        let (re, im) = xs.iter().fold((0.0, 0.0), |(r, i), x| {
            (r + (t * x).cos(), i + (t * x).sin())
        });
        let (re, im) = (re / n as f64, im / n as f64);
        let modulus = (-t.abs()).exp();
        let phase = -t.abs() * (2.0 / PI) * t.signum() * t.abs().ln();
        let (er, ei) = (modulus * phase.cos(), modulus * phase.sin());
        // Standard error of an empirical characteristic function ≤ 1/√n ≈ 1.6e-3.
        assert!(
            (re - er).abs() < 6e-3 && (im - ei).abs() < 6e-3,
            "t = {t}: ({re}, {im}) vs ({er}, {ei})"
        );
    }
    // Right-skewed but not positive-only; heavy right tail.
    let negative = xs.iter().filter(|&&x| x < 0.0).count() as f64 / n as f64;
    assert!(negative > 0.05 && negative < 0.5, "P(X < 0) = {negative}");
    assert!(xs.iter().any(|&x| x > 100.0));
}

fn stretched_patch() -> (Patch, Segmentation) {
    let seg = Segmentation::new(VinParams::default());
    let mesh = remembrane::mesh::icosphere(3, 1.0);
    let mut m = remembrane::mesh::membrane::Membrane::from_mesh(&mesh, false).unwrap();
    let t = m.topology().unwrap().clone();
    let [a, b] = t.edges[100];
    let moveable = rings(&t, &[a, b], 1);
    let (mut patch, _) = Patch::around(&t, &mesh.positions, &moveable, Some([a, b]));
    // Stretch the target edge from ≈ 1 to ≈ 1.4.
    let d = patch.positions[1] - patch.positions[0];
    patch.positions[0] -= 0.2 * d;
    patch.positions[1] += 0.2 * d;
    (patch, seg)
}

#[test]
fn relaxation_extends_compresses_and_keeps_the_boundary_fixed() {
    let (patch, seg) = stretched_patch();
    let settings = RelaxSettings {
        normal: (0.8, 1.2),
        kick_scale: 10.0,
        mobility: 1000.0,
        max_iterations: 50_000,
    };
    let len = |p: &Patch, k: usize| p.positions[p.edges[k][0]].distance(p.positions[p.edges[k][1]]);
    let kicks = KickTable::new(&mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(99));
    for seed in 0..3 {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut p = patch.clone();
        assert_eq!(
            relax(&mut p, Goal::Extend(1.8), &seg, &settings, &kicks, &mut rng).outcome,
            RelaxOutcome::Success
        );
        assert!(len(&p, p.target.unwrap()) > 1.8);
        for k in (0..p.edges.len()).filter(|&k| Some(k) != p.target) {
            assert!((0.8..=1.2).contains(&len(&p, k)));
        }
        assert_eq!(
            p.positions[p.moveable..],
            patch.positions[patch.moveable..],
            "boundary moved"
        );
        // Back into range: Normalize.
        let mut q = patch.clone();
        assert_eq!(
            relax(&mut q, Goal::Normalize, &seg, &settings, &kicks, &mut rng).outcome,
            RelaxOutcome::Success
        );
        assert!((0.8..=1.2).contains(&len(&q, q.target.unwrap())));
    }
    // A cap of zero iterations fails without moving anything.
    let mut p = patch.clone();
    let capped = RelaxSettings {
        max_iterations: 0,
        ..settings
    };
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(0);
    assert_eq!(
        relax(&mut p, Goal::Extend(1.8), &seg, &capped, &kicks, &mut rng),
        Relaxed {
            outcome: RelaxOutcome::Failure,
            iterations: capped.max_iterations
        }
    );
    assert_eq!(p.positions, patch.positions);
}

#[test]
fn remeshing_keeps_edges_in_range_valences_bounded_and_density_conserved() {
    let path = crate::common::repo("scenes/red_blood_cell_stiff.ron");
    let mut scene = Scene::load(&path).unwrap();
    scene.lipid_density = true;
    let mut sim = scene.build(&path).unwrap();
    let total = |sim: &remembrane::engine::simulation::Simulation| -> f64 {
        common::total_density(&sim.membrane())
    };
    let initial = total(&sim);
    let mut reported = 0;
    for _ in 0..3000 {
        sim.tick().unwrap();
        // A tick may end with abnormal edges only if it says so.
        let now = {
            let stats = sim.resource::<RemeshStats>();
            stats.overflow_ticks + stats.unresolved_ticks
        };
        if now > reported {
            reported = now;
            assert!(!sim.resource::<AbnormalEdges>().0.is_empty());
            continue;
        }
        let membrane = sim.membrane();
        let t = membrane.cached_topology();
        let p = sim.positions();
        for &[a, b] in &t.edges {
            let l = p[a as usize].distance(p[b as usize]);
            assert!(
                (0.7..=1.3).contains(&l),
                "iteration {}: edge length {l}",
                sim.clock().iteration
            );
        }
        for v in 0..t.vertex_count() {
            assert!((5..=8).contains(&t.valence(v)));
        }
        assert!((total(&sim) - initial).abs() < 1e-12 * initial);
    }
    let stats = sim.resource::<RemeshStats>();
    println!(
        "{:?} {:?} overflow {} unresolved {}",
        stats.split, stats.merge, stats.overflow_ticks, stats.unresolved_ticks
    );
    let summary = format!(
        "{:?} {:?} overflow {} unresolved {}",
        stats.split, stats.merge, stats.overflow_ticks, stats.unresolved_ticks
    );
    assert!(
        stats.split.success > 10 && stats.merge.success > 10,
        "{summary}"
    );
    // Measured: 0 of 3000 ticks end with an abnormal edge left (52 before
    // push-backs fell back to a 1-ring patch); bound at 5 % of ticks.
    assert!(
        stats.unresolved_ticks + stats.overflow_ticks < 150,
        "{summary}"
    );
}

#[test]
fn geometric_mode_removes_the_global_vin_force_only() {
    let path = crate::common::repo("scenes/red_blood_cell.ron");
    let mut scene = Scene::load(&path).unwrap();
    scene.remesh.mode = remembrane::params::RemeshMode::Geometric;
    let sim = scene.build(&path).unwrap();
    assert!(
        !sim.resource::<ForceBuffers>()
            .names()
            .contains(&"vin".to_string())
    );
    assert!(
        sim.resources().contains::<VinSegmentation>(),
        "V_in still sets Δt and relaxes patches"
    );
}

/// The holders' ring squeeze drives the remeshing churn of the filopodium:
/// the same scene with the centroid coupling (same net pull, no squeeze)
/// merges far fewer edges. Measured over the first 2000 iterations (seed 1):
/// 205 merge attempts as run, 14 with the centroid coupling.
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn centroid_coupling_removes_the_merge_churn_around_holders() {
    let merges = |name: &str| {
        let path = crate::common::repo("scenes").join(name);
        let mut scene = Scene::load(&path).unwrap();
        scene.dynamics.iterations = 2000;
        let mut sim = scene.build(&path).unwrap();
        for _ in 0..2000 {
            sim.tick().unwrap();
        }
        let m = sim.resource::<RemeshStats>().merge;
        println!("{name}: merge {m:?}");
        m.success + m.cancel + m.impossible + m.failure
    };
    let as_run = merges("filopodium_one_ring.ron");
    let centroid = merges("filopodium.ron");
    assert!(as_run > 100, "as run: {as_run} merges");
    assert!(
        4 * centroid < as_run,
        "centroid {centroid} vs as run {as_run} merges"
    );
}
