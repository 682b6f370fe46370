//! Radius of a membrane tube (a tether, a filopodium) by circle fits on
//! planes along its axis (reference §7f, `measureRtube.m`).
//!
//! Plane k passes through p_k = first + k·step with unit normal step/|step|.
//! The edges with an end point within `window` of p_k that cross the plane
//! give one intersection point each; with at least `min_points` of them the
//! points, expressed in the plane, are fitted with a circle (Pratt's
//! algebraic fit solved by Newton's method, as `ComMath.fit2Dcircle`). The
//! tube's radius is the mean over the planes that gave a fit.

use glam::DVec3;
use serde::{Deserialize, Serialize};

fn default_window() -> f64 {
    5.0
}
fn default_min_points() -> usize {
    11
}

/// Where to measure one tube (scene data).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TubeProbe {
    /// Column name in `series.csv` (`radius_<name>`, `radius_<name>_norm`).
    pub name: String,
    /// Point of the first plane (l̄).
    #[serde(deserialize_with = "crate::util::validate::finite_vec3")]
    pub first: (f64, f64, f64),
    /// Offset from one plane to the next; its direction is the plane normal
    /// (the tube axis) (l̄).
    #[serde(deserialize_with = "crate::util::validate::finite_vec3")]
    pub step: (f64, f64, f64),
    /// Number of planes (≥ 1).
    pub planes: usize,
    /// Only edges with an end point within this distance of a plane's
    /// point count (l̄; default 5).
    #[serde(default = "default_window")]
    pub window: f64,
    /// Fewest intersection points for a fit (default 11).
    #[serde(default = "default_min_points")]
    pub min_points: usize,
}

impl TubeProbe {
    /// Checks the probe's values; the error names the field.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let step = DVec3::new(self.step.0, self.step.1, self.step.2);
        if step.length() == 0.0 {
            return Err(("step", "must not be zero".into()));
        }
        if self.planes == 0 {
            return Err(("planes", "must be at least 1".into()));
        }
        if !(self.window.is_finite() && self.window > 0.0) {
            return Err(("window", format!("must be > 0 (got {})", self.window)));
        }
        if self.min_points < 3 {
            return Err((
                "min_points",
                format!("a circle needs at least 3 points (got {})", self.min_points),
            ));
        }
        Ok(())
    }

    /// Mean radius over the planes that gave a fit, and how many did.
    /// `None` if no plane did.
    pub fn measure(&self, positions: &[DVec3], edges: &[[u32; 2]]) -> Option<(f64, usize)> {
        let first = DVec3::new(self.first.0, self.first.1, self.first.2);
        let step = DVec3::new(self.step.0, self.step.1, self.step.2);
        let normal = step.normalize();
        let mut sum = 0.0;
        let mut fitted = 0;
        for k in 0..self.planes {
            let origin = first + k as f64 * step;
            if let Some(r) = section_radius(
                positions,
                edges,
                origin,
                normal,
                self.window,
                self.min_points,
            ) {
                sum += r;
                fitted += 1;
            }
        }
        (fitted > 0).then(|| (sum / fitted as f64, fitted))
    }
}

/// Radius of the section of the mesh by the plane through `origin` with unit
/// `normal`, from the edges with an end within `window` of `origin`.
pub fn section_radius(
    positions: &[DVec3],
    edges: &[[u32; 2]],
    origin: DVec3,
    normal: DVec3,
    window: f64,
    min_points: usize,
) -> Option<f64> {
    let (u, v) = normal.any_orthonormal_pair();
    let mut points = Vec::new();
    for &[a, b] in edges {
        let (pa, pb) = (positions[a as usize], positions[b as usize]);
        if pa.distance(origin) > window && pb.distance(origin) > window {
            continue;
        }
        let (da, db) = ((pa - origin).dot(normal), (pb - origin).dot(normal));
        if (da > 0.0) == (db > 0.0) || da == db {
            continue;
        }
        let p = pa + (pb - pa) * (da / (da - db)) - origin;
        points.push([p.dot(u), p.dot(v)]);
    }
    if points.len() < min_points {
        return None;
    }
    fit_circle(&points).map(|(_, r)| r)
}

/// Pratt's algebraic circle fit by Newton's method (Chernov's
/// `CircleFitByPratt`): centre and radius, `None` for fewer than 3 points or
/// collinear ones.
pub fn fit_circle(points: &[[f64; 2]]) -> Option<([f64; 2], f64)> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let nf = n as f64;
    let mx = points.iter().map(|p| p[0]).sum::<f64>() / nf;
    let my = points.iter().map(|p| p[1]).sum::<f64>() / nf;
    let (mut sxx, mut syy, mut sxy, mut sxz, mut syz, mut szz) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for p in points {
        let (x, y) = (p[0] - mx, p[1] - my);
        let z = x * x + y * y;
        sxx += x * x;
        syy += y * y;
        sxy += x * y;
        sxz += x * z;
        syz += y * z;
        szz += z * z;
    }
    let (mxx, myy, mxy, mxz, myz, mzz) =
        (sxx / nf, syy / nf, sxy / nf, sxz / nf, syz / nf, szz / nf);
    let mz = mxx + myy;
    let cov_xy = mxx * myy - mxy * mxy;
    let (mxz2, myz2) = (mxz * mxz, myz * myz);
    let a2 = 4.0 * cov_xy - 3.0 * mz * mz - mzz;
    let a1 = mzz * mz + 4.0 * cov_xy * mz - mxz2 - myz2 - mz * mz * mz;
    let a0 = mxz2 * myy + myz2 * mxx - mzz * cov_xy - 2.0 * mxz * myz * mxy + mz * mz * cov_xy;
    let a22 = a2 + a2;
    // Newton on the characteristic polynomial from x = 0 (converges to the
    // root that gives the fit; Chernov's stopping rules).
    let mut x = 0.0f64;
    let mut y = f64::MAX;
    let mut converged = false;
    for _ in 0..20 {
        let y_old = y;
        y = a0 + x * (a1 + x * (a2 + 4.0 * x * x));
        if y.abs() > y_old.abs() {
            x = 0.0;
            break;
        }
        let dy = a1 + x * (a22 + 16.0 * x * x);
        let x_old = x;
        x = x_old - y / dy;
        if x.is_nan() || x < 0.0 {
            x = 0.0;
            break;
        }
        if ((x - x_old) / x).abs() < 1e-12 {
            converged = true;
            break;
        }
    }
    if !converged {
        // Wrong direction, negative root or no convergence within the cap:
        // Chernov falls back to x = 0 (the Kåsa-like start).
        x = 0.0;
    }
    let det = x * x - x * mz + cov_xy;
    if det.abs() < f64::EPSILON * mz * mz {
        return None; // collinear points
    }
    let cx = (mxz * (myy - x) - myz * mxy) / det / 2.0;
    let cy = (myz * (mxx - x) - mxz * mxy) / det / 2.0;
    let r = (cx * cx + cy * cy + mz + 2.0 * x).sqrt();
    r.is_finite().then_some(([cx + mx, cy + my], r))
}
