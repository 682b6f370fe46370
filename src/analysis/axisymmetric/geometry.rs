//! The generating curve's nodes, its embeddedness, and the widths and
//! thicknesses measured on it.

use super::*;

/// `(r, z)` at the `N + 1` nodes for segment length `h`, from the north pole
/// at `(0, 0)`.
pub(super) fn nodes(x: &[f64], h: f64) -> (Vec<f64>, Vec<f64>) {
    let n = x.len() + 1;
    let mut r = vec![0.0; n + 1];
    let mut z = vec![0.0; n + 1];
    for i in 0..n {
        let phi = 0.5 * (node_angle(x, i) + node_angle(x, i + 1));
        r[i + 1] = r[i] + h * phi.cos();
        z[i + 1] = z[i] - h * phi.sin();
    }
    (r, z)
}

/// Rejects a generating curve that does not bound an embedded surface of
/// revolution: an interior node on or across the axis (`r_i ≤ 0`), the
/// north pole not above the south pole (the two sheets crossing on the
/// axis), or two non-adjacent segments of the polygon through the nodes
/// that cross or touch (e.g. the inner wall of an invagination meeting the
/// outer wall).
pub(super) fn check_embedded(r: &[f64], z: &[f64]) -> Result<(), SolveError> {
    let n = r.len() - 1;
    if let Some(i) = (1..n).find(|&i| r[i] <= 0.0 || !r[i].is_finite()) {
        return Err(SolveError::UnexpectedShape(format!(
            "the profile reaches the axis at interior node {i} (r = {:.3e})",
            r[i]
        )));
    }
    if z[0] <= z[n] {
        return Err(SolveError::UnexpectedShape(format!(
            "self-intersecting profile: the north pole is not above the south pole \
             (z_0 − z_N = {:.3e})",
            z[0] - z[n]
        )));
    }
    let p = |i: usize| (r[i], z[i]);
    for i in 0..n {
        let (a, b) = (p(i), p(i + 1));
        let (rmin, rmax) = (a.0.min(b.0), a.0.max(b.0));
        let (zmin, zmax) = (a.1.min(b.1), a.1.max(b.1));
        for j in i + 2..n {
            let (c, d) = (p(j), p(j + 1));
            if c.0.max(d.0) < rmin
                || c.0.min(d.0) > rmax
                || c.1.max(d.1) < zmin
                || c.1.min(d.1) > zmax
            {
                continue;
            }
            if segments_meet(a, b, c, d) {
                return Err(SolveError::UnexpectedShape(format!(
                    "self-intersecting profile: segments {i} and {j} meet near (r, z) = \
                     ({:.4}, {:.4})",
                    c.0, c.1
                )));
            }
        }
    }
    Ok(())
}

/// Twice the signed area of the triangle `(a, b, c)`.
pub(super) fn orientation(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> f64 {
    (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
}

/// `true` when the closed segments `ab` and `cd` share a point.
pub(super) fn segments_meet(a: (f64, f64), b: (f64, f64), c: (f64, f64), d: (f64, f64)) -> bool {
    let (o1, o2) = (orientation(a, b, c), orientation(a, b, d));
    let (o3, o4) = (orientation(c, d, a), orientation(c, d, b));
    if o1 * o2 < 0.0 && o3 * o4 < 0.0 {
        return true;
    }
    // Touching or collinear: an endpoint on the other segment.
    let within = |p: (f64, f64), q: (f64, f64), x: (f64, f64)| {
        x.0 >= p.0.min(q.0) && x.0 <= p.0.max(q.0) && x.1 >= p.1.min(q.1) && x.1 <= p.1.max(q.1)
    };
    (o1 == 0.0 && within(a, b, c))
        || (o2 == 0.0 && within(a, b, d))
        || (o3 == 0.0 && within(c, d, a))
        || (o4 == 0.0 && within(c, d, b))
}

/// Polynomial interpolant through consecutive nodes, in the node-index
/// coordinate `t` (node `k` at `t = k`).
pub(super) struct LocalPoly {
    pub(super) centre: f64,
    pub(super) coeffs: Vec<f64>,
}

impl LocalPoly {
    /// Interpolant of `values[first .. first + count]`.
    pub(super) fn fit(values: &[f64], first: usize, count: usize) -> Option<Self> {
        let centre = first as f64 + 0.5 * (count - 1) as f64;
        let mut a = DMatrix::<f64>::zeros(count, count);
        let mut b = DVector::<f64>::zeros(count);
        for row in 0..count {
            let u = (first + row) as f64 - centre;
            let mut p = 1.0;
            for col in 0..count {
                a[(row, col)] = p;
                p *= u;
            }
            b[row] = values[first + row];
        }
        let coeffs = a.lu().solve(&b)?.iter().copied().collect();
        Some(LocalPoly { centre, coeffs })
    }

    /// Value and derivative at `t`.
    pub(super) fn eval(&self, t: f64) -> (f64, f64) {
        let u = t - self.centre;
        let (mut p, mut dp) = (0.0, 0.0);
        for &c in self.coeffs.iter().rev() {
            dp = dp * u + p;
            p = p * u + c;
        }
        (p, dp)
    }
}

/// First node of a `count`-node stencil centred near `centre` within `0..=n`.
pub(super) fn stencil(centre: usize, count: usize, n: usize) -> usize {
    centre.saturating_sub(count / 2).min(n + 1 - count)
}

/// Index of the widest node and the smooth maximum of `r` around it.
pub(super) fn widest(r: &[f64]) -> (usize, f64) {
    smooth_max(r)
}

/// Index of the largest nodal value and the maximum of the degree-6
/// interpolant through the 7 nodes around it (smooth in the resolution). At
/// a pole (first or last node) the nodal value is returned: `r` and `z` are
/// even functions of the arc length about a pole, so an extremum there sits
/// exactly on the node.
pub(super) fn smooth_max(r: &[f64]) -> (usize, f64) {
    let n = r.len() - 1;
    let i_rim = (0..=n).fold(0, |best, i| if r[i] > r[best] { i } else { best });
    let nodal = r[i_rim];
    if i_rim == 0 || i_rim == n {
        return (i_rim, nodal);
    }
    let Some(poly) = LocalPoly::fit(r, stencil(i_rim, 7, n), 7) else {
        return (i_rim, nodal);
    };
    let mut t = i_rim as f64;
    for _ in 0..50 {
        // Newton on p'(t) = 0 with a central-difference p''.
        let (_, d1) = poly.eval(t);
        let eps = 1e-4;
        let d2 = (poly.eval(t + eps).1 - poly.eval(t - eps).1) / (2.0 * eps);
        if d2 >= 0.0 {
            break;
        }
        let dt = (-d1 / d2).clamp(-0.5, 0.5);
        t = (t + dt).clamp(i_rim as f64 - 1.0, i_rim as f64 + 1.0);
        if dt.abs() < 1e-14 {
            break;
        }
    }
    let smooth = poly.eval(t).0;
    (i_rim, if smooth >= nodal { smooth } else { nodal })
}

/// `max_r (z_upper(r) − z_lower(r))` from high-order interpolants of the
/// nodal profile (smooth in the resolution).
pub(super) fn max_thickness(r: &[f64], z: &[f64], i_rim: usize) -> Result<f64, SolveError> {
    let n = r.len() - 1;
    let upper_monotone = (0..i_rim).all(|i| r[i + 1] > r[i]);
    let lower_monotone = (i_rim..n).all(|i| r[i + 1] < r[i]);
    if !upper_monotone || !lower_monotone || i_rim < 2 || i_rim + 2 > n {
        return Err(SolveError::UnexpectedShape(
            "r is not monotone on the upper and lower halves".into(),
        ));
    }
    // z on the lower half at radius rr.
    let lower_z = |rr: f64| -> f64 {
        if rr <= r[n] {
            return z[n];
        }
        if rr >= r[i_rim] {
            return z[i_rim];
        }
        let (mut lo, mut hi) = (i_rim, n);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if r[mid] >= rr {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let first = stencil(lo, 6, n);
        let (Some(pr), Some(pz)) = (LocalPoly::fit(r, first, 6), LocalPoly::fit(z, first, 6))
        else {
            return z[lo];
        };
        let (mut a, mut b) = (lo as f64, lo as f64 + 1.0);
        for _ in 0..60 {
            let mid = 0.5 * (a + b);
            if pr.eval(mid).0 >= rr {
                a = mid;
            } else {
                b = mid;
            }
        }
        pz.eval(0.5 * (a + b)).0
    };
    let mut best = 0;
    let mut best_t = f64::NEG_INFINITY;
    for i in 0..i_rim {
        let t = z[i] - lower_z(r[i]);
        if t <= 0.0 {
            return Err(SolveError::UnexpectedShape(format!(
                "self-intersecting profile: the lower surface is above the upper one at r = {:.4}",
                r[i]
            )));
        }
        if t > best_t {
            best_t = t;
            best = i;
        }
    }
    let first = stencil(best, 7, n);
    let (Some(pr), Some(pz)) = (LocalPoly::fit(r, first, 7), LocalPoly::fit(z, first, 7)) else {
        return Ok(best_t);
    };
    let thickness = |t: f64| {
        let rr = pr.eval(t).0.max(0.0);
        pz.eval(t).0 - lower_z(rr)
    };
    // Golden-section search for the maximum on the neighbouring segments.
    let (mut a, mut b) = (
        best.saturating_sub(1) as f64,
        (best + 1).min(i_rim - 1) as f64,
    );
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (thickness(c), thickness(d));
    let mut top = best_t.max(thickness(a)).max(thickness(b));
    for _ in 0..80 {
        if fc > fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = thickness(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = thickness(d);
        }
        top = top.max(fc).max(fd);
    }
    Ok(top)
}
