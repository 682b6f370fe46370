//! The solver's tests: closed forms, orders, branches and stability.

use super::*;
use std::sync::OnceLock;
use std::time::Instant;

/// The reported pressure is the thermodynamic one: Δp = ∂E/∂V at fixed
/// area, checked against central differences of the minimal energy in
/// v (an envelope-theorem check, independent of the multiplier's sign
/// convention), and the tension obeys the dilation identity
/// 2σA = 3ΔpV. On the sphere (v = 1, bending alone) both vanish: the
/// Laplace relation Δp = 2σ/R holds as 0 = 0.
#[test]
pub(super) fn the_multipliers_are_the_pressure_and_tension_that_hold_the_shape() {
    let n = 200;
    for v in [0.6, 0.8] {
        assert_pressure_is_the_energy_slope(Branch::Oblate, v, n);
    }
    let sphere = solve(1.0, n).unwrap();
    assert_eq!((sphere.pressure, sphere.tension), (0.0, 0.0));
}

/// Checks on `branch` at `v` (on `n` segments) that the reported
/// pressure is Δp = ∂E/∂V at fixed area, against central differences of
/// the minimal energy in `v` (an envelope-theorem check, independent of
/// the multiplier's sign convention), and that the tension obeys the
/// dilation identity 2σA = 3ΔpV. Returns the shape at `v`.
pub(super) fn assert_pressure_is_the_energy_slope(
    branch: Branch,
    v: f64,
    n: usize,
) -> AxisymmetricShape {
    let dv = 1e-4;
    let shape = solve_on_branch(v, n, branch).unwrap();
    let e = |v: f64| solve_on_branch(v, n, branch).unwrap().energy_over_8pi_kappa * 8.0 * PI;
    let de_dv = (e(v + dv) - e(v - dv)) / (2.0 * dv);
    let fd_pressure = de_dv * 3.0 / (4.0 * PI);
    eprintln!(
        "{branch} v = {v}: Δp = {:.8} κ/R0³, ∂E/∂V = {fd_pressure:.8} κ/R0³",
        shape.pressure
    );
    assert!(
        (shape.pressure - fd_pressure).abs() < 1e-5 * fd_pressure.abs().max(1.0),
        "{branch} v = {v}: Δp = {} against ∂E/∂V = {fd_pressure}",
        shape.pressure
    );
    let (a, vol) = (shape.area, shape.volume);
    assert!((2.0 * shape.tension * a - 3.0 * shape.pressure * vol).abs() < 1e-6);
    shape
}

pub(super) fn converged_cached(v: f64) -> &'static ConvergedShape {
    static V060: OnceLock<ConvergedShape> = OnceLock::new();
    static V0665: OnceLock<ConvergedShape> = OnceLock::new();
    static V1: OnceLock<ConvergedShape> = OnceLock::new();
    let cell = if v == 0.6 {
        &V060
    } else if v == 0.665 {
        &V0665
    } else if v == 1.0 {
        &V1
    } else {
        panic!("no cache for v = {v}")
    };
    cell.get_or_init(|| {
        let t = Instant::now();
        let c = converged(v).expect("converged");
        eprintln!("converged({v}) took {:.2} s", t.elapsed().as_secs_f64());
        report(&c);
        c
    })
}

pub(super) fn report(c: &ConvergedShape) {
    eprintln!(
        "v = {}: E/8πκ = {:.10} ± {:.1e}, D = {:.8} ± {:.1e}, t_max = {:.8} ± {:.1e}, t_centre = {:.8} ± {:.1e}, orders {:?}",
        c.reduced_volume,
        c.energy_over_8pi_kappa.value,
        c.energy_over_8pi_kappa.error,
        c.diameter.value,
        c.diameter.error,
        c.max_thickness.value,
        c.max_thickness.error,
        c.centre_thickness.value,
        c.centre_thickness.error,
        c.observed_order
    );
    for s in &c.levels {
        eprintln!(
            "  N = {:4}: E/8πκ = {:.12}, D = {:.10}, t_max = {:.10}, t_c = {:.10}, λ_min = {:.4e}, |∇L| = {:.1e}, r_N = {:.1e}, dA = {:.1e}, dV = {:.1e}, iters {}",
            s.segments,
            s.energy_over_8pi_kappa,
            s.diameter,
            s.max_thickness,
            s.centre_thickness,
            s.min_tangent_hessian_eigenvalue,
            s.lagrangian_gradient_norm,
            s.closure_residual,
            s.area - 4.0 * PI,
            s.volume - s.reduced_volume * 4.0 * PI / 3.0,
            s.newton_iterations
        );
    }
}

#[test]
pub(super) fn analytic_gradients_match_finite_differences() {
    let n = 24;
    let mut x = spheroid_guess(0.8, n, Spheroid::Oblate);
    for (k, xi) in x.iter_mut().enumerate() {
        *xi += 0.05 * (0.7 * k as f64).sin();
    }
    let problem = Problem::closed(Some(0.7));
    let lambda = [0.3, -1.7];
    let k0 = problem.kkt(&x, &lambda).unwrap();
    let eps = 1e-6;
    let scalar =
        |k: &Kkt| k.ev.energy + lambda[0] * k.constraints[0] + lambda[1] * k.constraints[1];
    for i in 0..x.len() {
        let mut xp = x.clone();
        xp[i] += eps;
        let mut xm = x.clone();
        xm[i] -= eps;
        let kp = problem.kkt(&xp, &lambda).unwrap();
        let km = problem.kkt(&xm, &lambda).unwrap();
        let fd = (scalar(&kp) - scalar(&km)) / (2.0 * eps);
        assert!(
            (fd - k0.grad[i]).abs() < 1e-7,
            "i = {i}: fd {fd} analytic {}",
            k0.grad[i]
        );
        for c in 0..2 {
            let fdc = (kp.constraints[c] - km.constraints[c]) / (2.0 * eps);
            assert!(
                (fdc - k0.jacobian[c][i]).abs() < 1e-8,
                "constraint {c}, i = {i}"
            );
        }
    }
}

/// `E/κ` and `v` of the spheroid `r = sin θ`, `z = c cos θ` by Simpson
/// quadrature in `θ`, independent of the arc-length discretisation.
pub(super) fn spheroid_reference(c: f64) -> (f64, f64) {
    let m = 20_000;
    let (mut e, mut a, mut vol) = (0.0, 0.0, 0.0);
    for k in 0..=m {
        let t = PI * k as f64 / m as f64;
        let w = (t.cos().powi(2) + c * c * t.sin().powi(2)).sqrt();
        let (k1, k2) = (c / w.powi(3), c / w);
        let weight = if k == 0 || k == m {
            1.0
        } else if k % 2 == 1 {
            4.0
        } else {
            2.0
        } * PI
            / (3.0 * m as f64);
        e += weight * PI * t.sin() * (k1 + k2).powi(2) * w;
        a += weight * 2.0 * PI * t.sin() * w;
        vol += weight * PI * t.sin().powi(2) * c * t.sin();
    }
    (e, 3.0 * vol / (4.0 * PI) / (a / (4.0 * PI)).powf(1.5))
}

#[test]
pub(super) fn discrete_functionals_match_independent_quadrature() {
    for c in [0.45, 1.8] {
        let (e_ref, v_ref) = spheroid_reference(c);
        let family = if c < 1.0 {
            Spheroid::Oblate
        } else {
            Spheroid::Prolate
        };
        assert!((spheroid_reduced_volume(c) - v_ref).abs() < 1e-10);
        let mut errors = Vec::new();
        for n in [200, 400] {
            let ev = evaluate(&spheroid_guess(v_ref, n, family)).unwrap();
            let (de, dv) = (ev.energy - e_ref, reduced_volume_of(&ev) - v_ref);
            eprintln!(
                "spheroid c = {c}, N = {n}: E/8πκ = {:.8}, ΔE/8πκ = {:.2e}, Δv = {dv:.2e}",
                ev.energy / (8.0 * PI),
                de / (8.0 * PI)
            );
            assert!((de / (8.0 * PI)).abs() < 1e-3 && dv.abs() < 1e-4);
            errors.push(de);
        }
        let p = (errors[0] / errors[1]).abs().log2();
        assert!(p > 1.8 && p < 2.2, "order {p}");
        // Richardson on the two resolutions removes the h² term.
        let richardson = errors[1] + (errors[1] - errors[0]) / 3.0;
        assert!(
            richardson.abs() / (8.0 * PI) < 1e-7,
            "extrapolated error {richardson}"
        );
    }
}

/// `E/8πκ` at `v` on `n` segments, continuing along the given branch.
pub(super) fn branch_energy(v: f64, n: usize, branch: Branch) -> f64 {
    solve_on_branch(v, n, branch).unwrap().energy_over_8pi_kappa
}

#[test]
pub(super) fn prolate_oblate_crossing_matches_literature() {
    // Seifert, Berndl & Lipowsky (1991): for c0 = 0 the prolate and oblate
    // branches exchange stability (equal energy) at v ≈ 0.652.
    let gap =
        |v: f64| branch_energy(v, 200, Branch::Oblate) - branch_energy(v, 200, Branch::Prolate);
    let (mut a, mut b) = (0.63, 0.67);
    let (mut ga, mut gb) = (gap(a), gap(b));
    assert!(
        ga < 0.0 && gb > 0.0,
        "oblate must win below, prolate above: {ga} {gb}"
    );
    for _ in 0..6 {
        let m = b - gb * (b - a) / (gb - ga);
        let gm = gap(m);
        if gm < 0.0 {
            (a, ga) = (m, gm);
        } else {
            (b, gb) = (m, gm);
        }
    }
    let v_cross = b - gb * (b - a) / (gb - ga);
    eprintln!(
        "prolate/oblate crossing at v = {v_cross:.5}, E/8πκ = {:.5}",
        branch_energy(v_cross, 200, Branch::Oblate)
    );
    assert!((v_cross - 0.652).abs() < 0.005, "crossing at {v_cross}");
}

#[test]
pub(super) fn unit_reduced_volume_gives_the_sphere() {
    let s = solve(1.0, 100).unwrap();
    let h = s.contour_length / 100.0;
    // Discretisation error of the discrete sphere is O(h²).
    let err = (s.energy_over_8pi_kappa - 1.0).abs();
    eprintln!("sphere N=100: E/8πκ − 1 = {err:.3e}, h² = {:.3e}", h * h);
    assert!(err < h * h, "E/8πκ = {}", s.energy_over_8pi_kappa);
    assert!((s.contour_length - PI).abs() < h * h);
    let mut worst: f64 = 0.0;
    for (i, &(r, _)) in s.profile.iter().enumerate() {
        worst = worst.max((r - (i as f64 * h).sin()).abs());
    }
    eprintln!("sphere N=100: max |r_i − sin s_i| = {worst:.3e}");
    assert!(worst < h * h);
    assert!(s.is_constrained_minimum);
    assert!(!s.biconcave);
    let c = converged_cached(1.0);
    let e = c.energy_over_8pi_kappa;
    assert!((e.value - 1.0).abs() < 1e-6, "extrapolated E = {}", e.value);
    assert!(
        (e.value - 1.0).abs() <= e.error,
        "error bar must cover the exact value"
    );
    assert!((c.diameter.value - 2.0).abs() < 1e-6);
    assert!((c.centre_thickness.value - 2.0).abs() < 1e-6);
}

#[test]
pub(super) fn energy_converges_at_second_order() {
    let c = converged_cached(0.6);
    let e = c.energy_over_8pi_kappa.value;
    let errors: Vec<f64> = c
        .levels
        .iter()
        .map(|s| (s.energy_over_8pi_kappa - e).abs())
        .collect();
    for w in errors.windows(2).take(2) {
        let p = (w[0] / w[1]).log2();
        eprintln!("order from errors: {p:.4}");
        assert!(p > 1.8 && p < 2.2, "order {p}");
    }
    let p = c.observed_order[0];
    assert!(p > 1.8 && p < 2.2, "observed order {p}");
    assert!(c.energy_over_8pi_kappa.error < 1e-7);
}

pub(super) fn check_discocyte(c: &ConvergedShape) {
    assert!(c.biconcave, "not biconcave");
    assert!(c.is_constrained_minimum, "not a constrained minimum");
    assert!(c.max_thickness.value > c.centre_thickness.value + 10.0 * c.max_thickness.error);
    for s in &c.levels {
        assert!((s.area - 4.0 * PI).abs() < 1e-9);
        assert!((s.volume - s.reduced_volume * 4.0 * PI / 3.0).abs() < 1e-9);
        assert!(s.closure_residual.abs() < 1e-9);
        assert!(s.lagrangian_gradient_norm <= TOLERANCE);
        assert!(s.min_tangent_hessian_eigenvalue > 0.0);
        // The minimiser found is up-down symmetric.
        let n = s.segments;
        for i in 0..=n {
            let (r1, z1) = s.profile[i];
            let (r2, z2) = s.profile[n - i];
            assert!((r1 - r2).abs() < 1e-8 && (z1 + z2).abs() < 1e-8);
        }
    }
}

#[test]
pub(super) fn discocyte_at_v_0_6() {
    let c = converged_cached(0.6);
    check_discocyte(c);
    let e = c.energy_over_8pi_kappa.value;
    // Computed 1.95568; see the module report for why the often-quoted
    // 1.2-1.3 does not apply (that is the convex oblate range v ≈ 0.9).
    assert!(e > 1.9 && e < 2.0, "E/8πκ = {e}");
}

#[test]
pub(super) fn discocyte_at_v_0_665() {
    let c = converged_cached(0.665);
    check_discocyte(c);
}

#[test]
pub(super) fn convex_oblate_at_v_0_9() {
    let s = solve(0.9, 80).unwrap();
    assert!(!s.biconcave);
    assert!(s.is_constrained_minimum);
    assert_eq!(s.max_thickness, s.centre_thickness);
    assert!(s.energy_over_8pi_kappa > 1.0);
}

#[test]
pub(super) fn solve_matches_the_coarsest_converged_level() {
    let c = converged_cached(0.665);
    let s = solve(0.665, CONVERGED_LADDER[0]).unwrap();
    let l = &c.levels[0];
    assert_eq!(s.segments, l.segments);
    assert!((s.energy_over_8pi_kappa - l.energy_over_8pi_kappa).abs() < 1e-11);
    assert!((s.diameter - l.diameter).abs() < 1e-9);
}

#[test]
pub(super) fn hard_but_valid_inputs_do_not_panic() {
    // Too close to 1 for the resolution (the discrete sphere has
    // v = 1 − O(h²)), and past the self-contact of the poles near v ≈ 0.503:
    // either an error or a shape, never a panic.
    for v in [1.0 - 1e-9, 0.99999, 0.501] {
        match solve(v, 64) {
            Ok(s) => assert!(s.centre_thickness > 0.0),
            Err(e) => assert!(!e.to_string().is_empty()),
        }
    }
    assert!(matches!(
        solve(0.501, 64),
        Err(SolveError::UnexpectedShape(_))
    ));
    let s = solve(0.7, MIN_SEGMENTS).unwrap();
    assert!(s.biconcave && s.is_constrained_minimum);
}

#[test]
pub(super) fn bad_input_is_an_error() {
    for v in [0.5, 0.4, 1.0 + 1e-9, 2.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            solve(v, 100),
            Err(SolveError::InvalidReducedVolume(_))
        ));
        assert!(matches!(
            converged(v),
            Err(SolveError::InvalidReducedVolume(_))
        ));
    }
    for n in [0, 1, 3, MIN_SEGMENTS - 1, MAX_SEGMENTS + 1, usize::MAX] {
        assert!(matches!(solve(0.8, n), Err(SolveError::InvalidSegments(_))));
    }
    assert!(!SolveError::InvalidSegments(3).to_string().is_empty());
}

// -----------------------------------------------------------------------
// Prolate and stomatocyte branches, branch curves, embeddedness.
// -----------------------------------------------------------------------
