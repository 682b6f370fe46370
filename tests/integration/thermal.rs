//! The thermal noise has the right strength: exact results of overdamped
//! Langevin dynamics, r ← r + μFΔt + sqrt(2μk_BTΔt) ε, checked on
//! independent vertices (a harmonic trap per vertex, or no force at all),
//! with a fixed step, and with the displacement cap varying the step.
//!
//! Each tolerance is a multiple of the statistical standard error derived
//! from the number of independent samples (named constants below).

use glam::DVec3;
use remembrane::engine::force::{ForceContext, ForceTerm};
use remembrane::engine::simulation::{DensePositions, InitialState, SimBuilder, Simulation};
use remembrane::mesh::icosphere;
use remembrane::mesh::membrane::Membrane;
use remembrane::params::DynamicsParams;
use remembrane::scene::plugins;
use remembrane::timestep::TimeStepChoice;

/// Allowed deviation in standard errors (a false alarm every ~10^4 runs at
/// most; the seeds are fixed, so a pass is reproducible).
const SIGMAS: f64 = 4.0;
/// Mobility μ (l̄²/(Ē s)) and k_BT (Ē) of the tests.
const MOBILITY: f64 = 1.0;
const KBT: f64 = 0.0025;
/// Trap stiffness k (Ē/l̄²): σ = sqrt(k_BT/k) = 0.05 l̄, far below the
/// edge length, so no face can fold.
const TRAP: f64 = 1.0;

/// E = ½k Σ_i |x_i − x_i⁰|²: every vertex in its own harmonic well around
/// its initial position (no coupling between vertices).
struct Trap {
    k: f64,
    centres: Vec<DVec3>,
}

impl ForceTerm for Trap {
    fn name(&self) -> &str {
        "trap"
    }
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        for ((f, p), c) in force
            .into_iter()
            .flatten()
            .zip(ctx.positions)
            .zip(&self.centres)
        {
            *f += self.k * (*c - *p);
        }
        ctx.positions
            .iter()
            .zip(&self.centres)
            .map(|(p, c)| 0.5 * self.k * p.distance_squared(*c))
            .sum()
    }
}

/// An icosphere of `level` (mean edge 1) with independent vertices: a trap
/// of stiffness `k` per vertex (none if `k` is `None`), no other term.
fn simulation(
    level: u32,
    k: Option<f64>,
    dt_max: f64,
    max_displacement: f64,
    seed: u64,
) -> (Simulation, Vec<DVec3>) {
    simulation_of(icosphere(level, 1.0), k, dt_max, max_displacement, seed)
}

/// [`simulation`] on a given mesh.
fn simulation_of(
    mesh: remembrane::mesh::SurfaceMesh,
    k: Option<f64>,
    dt_max: f64,
    max_displacement: f64,
    seed: u64,
) -> (Simulation, Vec<DVec3>) {
    let membrane = Membrane::from_mesh(&mesh, false).unwrap();
    let initial = InitialState {
        vertices: mesh.vertex_count(),
        lipid_total: mesh.vertex_count() as f64,
        area: 0.0,
        volume: 0.0,
    };
    let mut b = SimBuilder::new(membrane, initial);
    b.add_plugin(plugins::core(plugins::CoreSettings {
        dynamics: DynamicsParams {
            mobility: MOBILITY,
            temperature: KBT,
            dt_max,
            max_displacement,
            ..Default::default()
        },
        seed,
        penalty_smoothing: 0,
        remesh: Default::default(),
    }))
    .unwrap();
    if let Some(k) = k {
        b.add_force_term(Trap {
            k,
            centres: mesh.positions.clone(),
        })
        .unwrap();
    }
    let mut sim = b.build().unwrap();
    sim.evaluate_forces().unwrap();
    (sim, mesh.positions)
}

/// Per-component second moments about the trap centres over `steps` ticks
/// after `burn_in`: (averaged per step, averaged per unit of simulated time
/// with each state weighted by the step taken from it, mean step).
fn trap_moments(
    sim: &mut Simulation,
    centres: &[DVec3],
    burn_in: usize,
    steps: usize,
) -> (f64, f64, f64) {
    for _ in 0..burn_in {
        sim.tick().unwrap();
    }
    let components = 3.0 * centres.len() as f64;
    let (mut per_step, mut per_time, mut time) = (0.0, 0.0, 0.0);
    for _ in 0..steps {
        let m2: f64 = sim
            .resource::<DensePositions>()
            .0
            .iter()
            .zip(centres)
            .map(|(p, c)| p.distance_squared(*c))
            .sum::<f64>()
            / components;
        sim.tick().unwrap();
        let dt = sim.resource::<TimeStepChoice>().dt;
        per_step += m2;
        per_time += m2 * dt;
        time += dt;
    }
    (
        per_step / steps as f64,
        per_time / time,
        time / steps as f64,
    )
}

/// Standard error of a variance estimate from `samples` independent
/// Gaussian samples, relative to the variance: sqrt(2 / samples).
fn relative_error(samples: f64) -> f64 {
    (2.0 / samples).sqrt()
}

#[test]
fn a_vertex_in_a_harmonic_well_has_variance_kbt_over_k_per_component() {
    // Fixed step h = 0.01 s (no cap): μkh = 0.01. Forward Euler's exact
    // stationary variance is k_BT/k / (1 − μkh/2), 0.5 % above the
    // continuum's; the test checks the exact discrete value.
    let h = 0.01;
    let (mut sim, centres) = simulation(3, Some(TRAP), h, 1e9, 3);
    let steps = 20_000;
    let (per_step, _, mean_dt) = trap_moments(&mut sim, &centres, 2000, steps);
    assert!((mean_dt - h).abs() < 1e-12, "the step is fixed");
    let a = MOBILITY * TRAP * h;
    let exact = KBT / TRAP / (1.0 - a / 2.0);
    // Correlation time 1/(μkh) = 100 steps; (1 + ρ)/(1 − ρ) steps per
    // independent sample of x², ρ = (1 − a)² the lag-one correlation of x².
    let rho = (1.0 - a) * (1.0 - a);
    let samples = steps as f64 * 3.0 * centres.len() as f64 * (1.0 - rho) / (1.0 + rho);
    let tolerance = SIGMAS * relative_error(samples);
    let deviation = per_step / exact - 1.0;
    println!(
        "<x²> = {per_step:.6e}, exact discrete {exact:.6e} (continuum {:.6e}): {:+.3} % (tolerance {:.3} %)",
        KBT / TRAP,
        100.0 * deviation,
        100.0 * tolerance
    );
    assert!(deviation.abs() < tolerance);
}

#[test]
fn free_diffusion_has_msd_6_mu_kbt_t_per_vertex_and_over_n_for_the_centroid() {
    // No force: every step is dt_max; each vertex's displacement over a
    // window of time t is Gaussian with variance 2μk_BT t per component,
    // independent between disjoint windows (Brownian increments). The mesh
    // has edges of 10 l̄ so that the random walk (0.3 l̄ over a run) cannot
    // fold it.
    let h = 0.01;
    let (runs, windows, window) = (40, 20, 100);
    let t = h * window as f64;
    let (mut msd, mut centroid_msd, mut samples, mut n) = (0.0, 0.0, 0.0, 0.0);
    for seed in 0..runs {
        let mesh = icosphere(2, 10.0);
        let (mut sim, _) = simulation_of(mesh, None, h, 1e9, 100 + seed);
        for _ in 0..windows {
            let start = sim.positions();
            for _ in 0..window {
                sim.tick().unwrap();
            }
            let p = sim.positions();
            n = p.len() as f64;
            msd += p
                .iter()
                .zip(&start)
                .map(|(a, b)| a.distance_squared(*b))
                .sum::<f64>()
                / n;
            let shift = p.iter().zip(&start).map(|(a, b)| *a - *b).sum::<DVec3>() / n;
            centroid_msd += shift.length_squared();
            samples += 1.0;
        }
    }
    let (msd, centroid_msd) = (msd / samples, centroid_msd / samples);
    let expected = 6.0 * MOBILITY * KBT * t;
    // A squared 3-D Gaussian displacement has relative standard deviation
    // sqrt(2/3): over n vertices × windows independent samples, and over the
    // windows for the centroid.
    let vertex_tolerance = SIGMAS * (2.0 / 3.0 / (n * samples)).sqrt();
    let centroid_tolerance = SIGMAS * (2.0 / 3.0 / samples).sqrt();
    println!(
        "MSD {msd:.5e} vs 6μk_BTt = {expected:.5e} ({:+.2} %, tolerance {:.2} %); centroid {centroid_msd:.5e} vs /N = {:.5e} ({:+.1} %, tolerance {:.1} %)",
        100.0 * (msd / expected - 1.0),
        100.0 * vertex_tolerance,
        expected / n,
        100.0 * (centroid_msd * n / expected - 1.0),
        100.0 * centroid_tolerance
    );
    assert!((msd / expected - 1.0).abs() < vertex_tolerance);
    assert!((centroid_msd * n / expected - 1.0).abs() < centroid_tolerance);
}

#[test]
fn with_the_displacement_cap_varying_the_step_time_averages_are_unbiased_and_step_averages_are_not()
{
    // 12 vertices (icosahedron) in traps; the cap s_max = 0.002 l̄ binds at
    // every step (max |μF| ≈ 0.1-0.2 l̄/s → Δt ≈ 0.01-0.02 s < dt_max), so
    // Δt follows the largest displacement. Each step is a valid Euler step
    // of its own Δt, so averages over *time* (each state weighted by the
    // step taken from it) sample k_BT/k, up to Euler's O(μkΔt) bias; plain
    // averages over *steps* over-weight the short steps taken from
    // stretched states. A user who samples frames by iteration
    // (`dynamics.frames`) with an active cap gets the biased one;
    // `dynamics.frame_time` samples by time.
    let (mut sim, centres) = simulation(0, Some(TRAP), 1.0, 0.002, 5);
    let steps = 400_000;
    let (per_step, per_time, mean_dt) = trap_moments(&mut sim, &centres, 5000, steps);
    let continuum = KBT / TRAP;
    // Euler's bias at the mean step (the exact discrete factor for a fixed
    // step of that size).
    let euler = 1.0 / (1.0 - MOBILITY * TRAP * mean_dt / 2.0) - 1.0;
    let a = MOBILITY * TRAP * mean_dt;
    let rho = (1.0 - a) * (1.0 - a);
    let samples = steps as f64 * 3.0 * centres.len() as f64 * (1.0 - rho) / (1.0 + rho);
    let tolerance = SIGMAS * relative_error(samples) + euler;
    let time_deviation = per_time / continuum - 1.0;
    let step_deviation = per_step / continuum - 1.0;
    println!(
        "mean Δt {mean_dt:.4e} s; time average {:+.2} %, step average {:+.2} % (tolerance {:.2} %, of which Euler {:.2} %)",
        100.0 * time_deviation,
        100.0 * step_deviation,
        100.0 * tolerance,
        100.0 * euler
    );
    assert!(time_deviation.abs() < tolerance, "time average is biased");
    assert!(
        step_deviation > tolerance,
        "the step average's bias is detected"
    );
}

/// A 162-vertex vesicle at 300 K with V_in barriers of 10 k_BT (v0 = 2 Ē),
/// built from a scene with `vin_step_limit` set as given; returns the steps
/// (s) of its first `ticks` ticks.
fn vin_vesicle_steps(vin_step_limit: bool, ticks: u64) -> Vec<f64> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("vesicle.ron");
    std::fs::write(
        &path,
        format!(
            r#"Scene(
            name: "vin_step_rule",
            membrane: Icosphere(level: 2, mean_edge_length: 1.0),
            energy: [Vin(v0: 2.0), Bending(kappa: 1.5)],
            dynamics: (temperature: 0.1, dt_max: 2e-6, vin_step_limit: {vin_step_limit}),
        )"#
        ),
    )
    .unwrap();
    let mut sim = remembrane::scene::Scene::load(&path)
        .unwrap()
        .build(&path)
        .unwrap();
    (0..ticks)
        .map(|_| {
            sim.tick().unwrap();
            sim.resource::<TimeStepChoice>().dt
        })
        .collect()
}

/// V_in's edge rule bounds the drift to one segment per step; with noise
/// that crosses many segments per step it only shrinks Δt. Turned off, the
/// step is `dt_max` (the bending bound, 0.04 l_min²/(μκ) ≈ 1.5e-5 s here,
/// does not bind), and the run stays healthy.
#[test]
fn without_the_vin_edge_rule_a_noisy_run_steps_at_dt_max() {
    let with_rule = vin_vesicle_steps(true, 200);
    let smallest = with_rule.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(
        smallest < 2e-7,
        "with the rule: smallest step {smallest:e} s"
    );
    let without = vin_vesicle_steps(false, 200);
    assert!(without.iter().all(|&dt| dt == 2e-6), "{without:?}");
}
