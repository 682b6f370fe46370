//! Starting shapes (spheroids, the stomatocyte's cup) and their
//! prolongation onto finer grids.

use super::*;

/// Which family of spheroids starts the continuation of a symmetric branch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Spheroid {
    /// Flattened along the axis (starts the oblate/discocyte branch).
    Oblate,
    /// Elongated along the axis (starts the prolate branch).
    Prolate,
}

/// Reduced volume of a spheroid with equatorial radius 1 and polar semi-axis
/// `c` (oblate for `c < 1`, prolate for `c > 1`).
pub(super) fn spheroid_reduced_volume(c: f64) -> f64 {
    let e = (1.0 - c.min(1.0 / c).powi(2)).max(0.0).sqrt();
    let area_over_4pi = if c <= 1.0 {
        let atanh_over_e = if e < 1e-4 {
            1.0 + e * e / 3.0 + e.powi(4) / 5.0
        } else {
            e.atanh() / e
        };
        0.5 * (1.0 + c * c * atanh_over_e)
    } else {
        let asin_over_e = if e < 1e-4 {
            1.0 + e * e / 6.0 + 3.0 * e.powi(4) / 40.0
        } else {
            e.asin() / e
        };
        0.5 * (1.0 + c * asin_over_e)
    };
    c / area_over_4pi.powf(1.5)
}

/// Interior tangent angles of a spheroid of reduced volume `v` of the given
/// family, sampled at `n` equal arc-length segments.
pub(super) fn spheroid_guess(v: f64, n: usize, family: Spheroid) -> Vec<f64> {
    // v(c) increases on (0, 1] and decreases on [1, ∞).
    let (mut lo, mut hi) = match family {
        Spheroid::Oblate => (1e-3, 1.0),
        Spheroid::Prolate => (1.0, 50.0),
    };
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        let below = spheroid_reduced_volume(mid) < v;
        if below == (family == Spheroid::Oblate) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let c = 0.5 * (lo + hi);
    let samples = 20_000;
    let mut s = vec![0.0; samples + 1];
    let mut psi = vec![0.0; samples + 1];
    let speed = |t: f64| (t.cos().powi(2) + c * c * t.sin().powi(2)).sqrt();
    for k in 0..=samples {
        let t = PI * k as f64 / samples as f64;
        psi[k] = (c * t.sin()).atan2(t.cos());
        if k > 0 {
            let t0 = PI * (k - 1) as f64 / samples as f64;
            s[k] = s[k - 1] + 0.5 * (speed(t0) + speed(t)) * (t - t0);
        }
    }
    let total = s[samples];
    (1..n)
        .map(|i| {
            let target = total * i as f64 / n as f64;
            let k = s.partition_point(|&si| si <= target).clamp(1, samples);
            let w = (target - s[k - 1]) / (s[k] - s[k - 1]);
            psi[k - 1] + w * (psi[k] - psi[k - 1])
        })
        .collect()
}

/// Interior tangent angles of the piecewise-circular cup that seeds the
/// stomatocyte branch, sampled at `n` equal arc-length segments.
///
/// With the outer radius as unit, the generating curve is, from the north
/// pole: an arc of the inner sphere of radius `a` (`ψ` falls linearly from 0
/// to `−α`: the floor and the undercut wall of the invagination), an arc of
/// the rim torus of tube radius `b` (`ψ` rises from `−α` to `β`), and an arc of
/// the outer unit sphere (`ψ` rises from `β` to `π`). Its radial closure
/// `a sin α + b (sin α + sin β) − sin β = 0` fixes `β`, so `ψ(s)` is
/// continuous and the continuum curve closes exactly; the scale drops out
/// (the area is fixed by `h`). `(a, b, α)` = [`STOMATOCYTE_SEED`].
pub(super) fn stomatocyte_guess(n: usize) -> Vec<f64> {
    cup_guess(n, STOMATOCYTE_SEED)
}

/// The piecewise-circular cup of [`stomatocyte_guess`] with parameters
/// `(a, b, α)`; requires `(a + b) sin α ≤ 1 − b` (else `β` is undefined and
/// the angles are NaN, which [`evaluate`] rejects).
pub(super) fn cup_guess(n: usize, (a, b, alpha): (f64, f64, f64)) -> Vec<f64> {
    let beta = ((a + b) * alpha.sin() / (1.0 - b)).asin();
    let (l1, l2, l3) = (a * alpha, b * (alpha + beta), PI - beta);
    let length = l1 + l2 + l3;
    (1..n)
        .map(|i| {
            let s = length * i as f64 / n as f64;
            if s < l1 {
                -s / a
            } else if s < l1 + l2 {
                -alpha + (s - l1) / b
            } else {
                beta + (s - l1 - l2)
            }
        })
        .collect()
}

/// Cubic interpolation of a converged profile onto `n_fine` segments, in the
/// normalised arc length `s/L`, using the odd extension of `ψ` through the
/// poles (`ψ(−s) = −ψ(s)`, `ψ(L+s) = 2π − ψ(L−s)`).
pub(super) fn prolong(x: &[f64], n_fine: usize) -> Vec<f64> {
    let nc = (x.len() + 1) as i64;
    let psi = |k: i64| -> f64 {
        if k < 0 {
            -node_angle(x, (-k) as usize)
        } else if k > nc {
            2.0 * PI - node_angle(x, (2 * nc - k) as usize)
        } else {
            node_angle(x, k as usize)
        }
    };
    (1..n_fine)
        .map(|j| {
            let t = j as f64 * nc as f64 / n_fine as f64;
            let k = t.floor() as i64;
            let u = t - k as f64;
            let w0 = -u * (u - 1.0) * (u - 2.0) / 6.0;
            let w1 = (u + 1.0) * (u - 1.0) * (u - 2.0) / 2.0;
            let w2 = -(u + 1.0) * u * (u - 2.0) / 2.0;
            let w3 = (u + 1.0) * u * (u - 1.0) / 6.0;
            w0 * psi(k - 1) + w1 * psi(k) + w2 * psi(k + 1) + w3 * psi(k + 2)
        })
        .collect()
}
