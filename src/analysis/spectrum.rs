//! Flicker spectroscopy of a quasi-spherical vesicle: `remembrane spectrum
//! RUN_DIR`.
//!
//! Each frame's shape is written r(Ω) = R0 (1 + u(Ω)) about its volume
//! centroid, R0 the mean radius (so ∫u dΩ = 0), and projected onto real
//! orthonormal spherical harmonics, u_lm = ∫ u Y_lm dΩ. The integral is a
//! quadrature over the mesh's faces: a 7-point degree-5 rule on each flat
//! triangle, the radius at each point interpolated linearly from the
//! vertices, the direction that of the point seen from the centroid, and
//! the weight the triangle's solid-angle density (p − c)·n / |p − c|³. The
//! mean ⟨u_lm²⟩ over m and over the frames after an equilibration time is
//! fitted by the Helfrich quasi-spherical spectrum
//!
//! ⟨|u_lm|²⟩ = k_BT / (κ (l − 1)(l + 2) [l(l + 1) + σ̄]),  σ̄ = σ R0² / κ,
//!
//! which is linear in (κ/k_BT, σR0²/k_BT) for 1/⟨|u_lm|²⟩: a weighted least
//! squares fit whose weights and error bars come from block averages over
//! the (correlated) frames. Sample frames by time (`dynamics.frame_time`):
//! the step varies with the state, and per-iteration frames over-weight
//! short steps (tests/integration/thermal.rs).

use glam::DVec3;
use std::f64::consts::PI;

/// Index of (l, m) in a vector of real harmonics up to some l_max:
/// l² + l + m, m = −l..=l.
pub fn lm_index(l: usize, m: i64) -> usize {
    ((l * l + l) as i64 + m) as usize
}

/// The real orthonormal spherical harmonics Y_lm(θ, φ) for l ≤ `l_max` at
/// the unit direction `d`, indexed by [`lm_index`]: Y_l0 = P̄_l^0,
/// Y_lm = √2 P̄_l^m cos(mφ) (m > 0), Y_l,−m = √2 P̄_l^m sin(mφ), with P̄ the
/// fully normalised associated Legendre functions (∫ Y² dΩ = 1).
pub fn real_harmonics(l_max: usize, d: DVec3, out: &mut Vec<f64>) {
    let n = (l_max + 1) * (l_max + 1);
    out.clear();
    out.resize(n, 0.0);
    let x = d.z.clamp(-1.0, 1.0);
    let s = (1.0 - x * x).max(0.0).sqrt();
    let phi = d.y.atan2(d.x);
    // p[l][m] for the current m column, by the standard stable recurrences.
    let mut pmm = (1.0 / (4.0 * PI)).sqrt();
    for m in 0..=l_max {
        if m > 0 {
            pmm *= -((2 * m + 1) as f64 / (2 * m) as f64).sqrt() * s;
        }
        let (cos_m, sin_m) = ((m as f64) * phi).cos_sin();
        let mut put = |l: usize, p: f64| {
            if m == 0 {
                out[l * l + l] = p;
            } else {
                out[l * l + l + m] = std::f64::consts::SQRT_2 * p * cos_m;
                out[l * l + l - m] = std::f64::consts::SQRT_2 * p * sin_m;
            }
        };
        put(m, pmm);
        if m == l_max {
            break;
        }
        let mut p_prev = pmm;
        let mut p = (2.0 * m as f64 + 3.0).sqrt() * x * pmm;
        put(m + 1, p);
        for l in m + 2..=l_max {
            let (lf, mf) = (l as f64, m as f64);
            let a = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
            let lp = lf - 1.0;
            let a_prev = ((4.0 * lp * lp - 1.0) / (lp * lp - mf * mf)).sqrt();
            let next = a * (x * p - p_prev / a_prev);
            p_prev = p;
            p = next;
            put(l, p);
        }
    }
}

trait CosSin {
    fn cos_sin(self) -> (f64, f64);
}

impl CosSin for f64 {
    fn cos_sin(self) -> (f64, f64) {
        let (s, c) = self.sin_cos();
        (c, s)
    }
}

/// The 7-point degree-5 rule on a triangle (Radon): barycentric points
/// ((9 ∓ 2√15)/21, (6 ± √15)/21, ...) and weights 9/40, (155 ± √15)/1200,
/// summing to 1.
const RULE: [([f64; 3], f64); 7] = {
    const A1: f64 = 0.05971587178976981;
    const B1: f64 = 0.47014206410511505;
    const A2: f64 = 0.7974269853530872;
    const B2: f64 = 0.10128650732345633;
    const W0: f64 = 0.225;
    const W1: f64 = 0.13239415278850616;
    const W2: f64 = 0.12593918054482717;
    [
        ([1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0], W0),
        ([A1, B1, B1], W1),
        ([B1, A1, B1], W1),
        ([B1, B1, A1], W1),
        ([A2, B2, B2], W2),
        ([B2, A2, B2], W2),
        ([B2, B2, A2], W2),
    ]
};

/// The shape of one frame in harmonics.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeModes {
    /// Mean radius R0 about the volume centroid (l̄).
    pub mean_radius: f64,
    /// u_lm for l ≤ l_max, by [`lm_index`] (dimensionless).
    pub modes: Vec<f64>,
}

/// Projects a closed mesh onto real spherical harmonics up to `l_max` (see
/// the module doc).
pub fn project(positions: &[DVec3], faces: &[[u32; 3]], l_max: usize) -> ShapeModes {
    // Volume centroid: Σ over tetrahedra (0, a, b, c) of volume × centroid.
    let (mut six_v, mut moment) = (0.0, DVec3::ZERO);
    for f in faces {
        let [a, b, c] = f.map(|v| positions[v as usize]);
        let v = a.dot(b.cross(c));
        six_v += v;
        moment += v * (a + b + c) / 4.0;
    }
    let centre = moment / six_v;
    let radius: Vec<f64> = positions.iter().map(|p| p.distance(centre)).collect();
    // Quadrature points: (direction, radius, solid-angle weight).
    let mut points = Vec::with_capacity(faces.len() * RULE.len());
    for f in faces {
        let [ia, ib, ic] = f.map(|v| v as usize);
        let [a, b, c] = [positions[ia], positions[ib], positions[ic]];
        let cross = (b - a).cross(c - a);
        let area = 0.5 * cross.length();
        let normal = cross.normalize_or_zero();
        for (w, weight) in RULE {
            let p = w[0] * a + w[1] * b + w[2] * c;
            let q = p - centre;
            let dist = q.length();
            let solid = area * weight * q.dot(normal) / (dist * dist * dist);
            let r = w[0] * radius[ia] + w[1] * radius[ib] + w[2] * radius[ic];
            points.push((q / dist, r, solid));
        }
    }
    let total: f64 = points.iter().map(|p| p.2).sum();
    let mean_radius = points.iter().map(|p| p.1 * p.2).sum::<f64>() / total;
    let mut modes = vec![0.0; (l_max + 1) * (l_max + 1)];
    let mut y = Vec::new();
    for &(d, r, w) in &points {
        real_harmonics(l_max, d, &mut y);
        let u = (r - mean_radius) / mean_radius;
        for (m, yk) in modes.iter_mut().zip(&y) {
            *m += w * u * yk;
        }
    }
    ShapeModes { mean_radius, modes }
}

/// The mean of u_lm² over m for each l ≤ l_max (index l).
pub fn power_by_l(modes: &[f64], l_max: usize) -> Vec<f64> {
    (0..=l_max)
        .map(|l| {
            let s = &modes[l * l..(l + 1) * (l + 1)];
            s.iter().map(|u| u * u).sum::<f64>() / s.len() as f64
        })
        .collect()
}

/// The measured spectrum and its Helfrich fit.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Spectrum {
    /// Frames averaged (after the equilibration time).
    pub frames: usize,
    /// Blocks for the error bars.
    pub blocks: usize,
    /// Mean radius over the frames (l̄).
    pub mean_radius: f64,
    /// Modes fitted: l_min..=l_max.
    pub l_min: usize,
    /// See `l_min`.
    pub l_max: usize,
    /// ⟨|u_lm|²⟩ by l (index l; 0 and 1 unused).
    pub power: Vec<f64>,
    /// Standard error of `power` from the block averages.
    pub power_error: Vec<f64>,
    /// Fitted bending modulus κ (Ē).
    pub kappa: f64,
    /// Its standard error (Ē).
    pub kappa_error: f64,
    /// Fitted tension σ (Ē/l̄²).
    pub sigma: f64,
    /// Its standard error (Ē/l̄²).
    pub sigma_error: f64,
    /// χ² per degree of freedom of the fit.
    pub chi2_per_dof: f64,
    /// k_BT used (Ē).
    pub kbt: f64,
    /// The discrete energy's stiffness against mode l over the continuum's
    /// (index l), when the fit was against it (`--discrete`); empty: the
    /// continuum.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub stiffness: Vec<f64>,
}

/// Helfrich's ⟨|u_lm|²⟩ for modulus `kappa`, tension `sigma` and radius `r`.
pub fn helfrich_power(l: usize, kbt: f64, kappa: f64, sigma: f64, r: f64) -> f64 {
    let lf = l as f64;
    let sigma_bar = sigma * r * r / kappa;
    kbt / (kappa * (lf - 1.0) * (lf + 2.0) * (lf * (lf + 1.0) + sigma_bar))
}

/// ⟨|u_lm|²⟩ of the quasi-spherical model whose bending stiffness against
/// mode l is `stiffness` times the continuum's (1 for the continuum,
/// [`helfrich_power`]): k_BT / ((l−1)(l+2)[s_l κ l(l+1) + σR²]).
pub fn model_power(l: usize, kbt: f64, kappa: f64, sigma: f64, r: f64, stiffness: f64) -> f64 {
    let lf = l as f64;
    kbt / ((lf - 1.0) * (lf + 2.0) * (stiffness * kappa * lf * (lf + 1.0) + sigma * r * r))
}

/// The discrete bending energy's stiffness against the shape mode
/// δR/R = ε Y_lm, over the continuum's κ(l−1)(l+2)l(l+1): the mesh's
/// vertices are put on the sphere of their mean radius (about their
/// centroid) and the energy's second difference in ε is averaged over four
/// m. Below 1 for modes a few edges long (0.956 at l = 7 on a 2562-vertex
/// sphere, 0.835 on a 642-vertex one): the cotangent energy is softer than
/// the continuum there, and thermal amplitudes larger by the inverse.
pub fn discrete_mode_stiffness(positions: &[DVec3], faces: &[[u32; 3]], l: usize) -> f64 {
    use crate::energy::bending::{BendingScratch, bending};
    let n = positions.len() as f64;
    let centroid = positions.iter().copied().sum::<DVec3>() / n;
    let r = positions
        .iter()
        .map(|p| (*p - centroid).length())
        .sum::<f64>()
        / n;
    let base: Vec<DVec3> = positions
        .iter()
        .map(|p| (*p - centroid).normalize() * r)
        .collect();
    let mut geometry = Vec::new();
    let mut scratch = BendingScratch::default();
    let mut energy = |p: &[DVec3]| {
        crate::mesh::geometry::face_geometry(p, faces, &mut geometry);
        bending(p.len(), faces, &geometry, 1.0, 0.0, &mut scratch, None)
    };
    // ε: small against the mode's amplitude scale, large against round-off
    // (the second difference is exact for a quadratic energy).
    let eps = 1e-4;
    let e0 = energy(&base);
    let ms = [0, 1, -2, l as i64];
    // Y_l,m at every vertex for the four m, evaluated once.
    let mut y = Vec::new();
    let harmonics: Vec<[f64; 4]> = base
        .iter()
        .map(|q| {
            real_harmonics(l, q.normalize(), &mut y);
            ms.map(|m| y[lm_index(l, m)])
        })
        .collect();
    let mut sum = 0.0;
    for k in 0..ms.len() {
        let shaped = |s: f64| -> Vec<DVec3> {
            base.iter()
                .zip(&harmonics)
                .map(|(q, y)| *q * (1.0 + s * y[k]))
                .collect()
        };
        let (plus, minus) = (shaped(eps), shaped(-eps));
        sum += (energy(&plus) + energy(&minus) - 2.0 * e0) / (eps * eps);
    }
    let lf = l as f64;
    sum / ms.len() as f64 / ((lf - 1.0) * (lf + 2.0) * lf * (lf + 1.0))
}

/// Why the spectrum could not be fitted.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FitError {
    /// The range of l is not 2 ≤ l_min < l_max.
    #[error("need 2 <= l_min < l_max (got {l_min}..={l_max})")]
    Range {
        /// Lowest l.
        l_min: usize,
        /// Highest l.
        l_max: usize,
    },
    /// Fewer frames than blocks.
    #[error("{frames} frames after the equilibration time, fewer than the {blocks} blocks")]
    TooFewFrames {
        /// Frames after the equilibration time.
        frames: usize,
        /// Blocks asked for.
        blocks: usize,
    },
    /// The least-squares system is singular.
    #[error("the fit is degenerate (zero or non-finite error bars?)")]
    Degenerate,
}

/// Averages the per-frame powers (`frames`: (mean radius, power by l)) in
/// `blocks` contiguous blocks and fits κ and σ over l_min..=l_max.
pub fn fit(
    frames: &[(f64, Vec<f64>)],
    blocks: usize,
    l_min: usize,
    l_max: usize,
    kbt: f64,
) -> Result<Spectrum, FitError> {
    fit_against(frames, blocks, l_min, l_max, kbt, &[])
}

/// [`fit`] against the model whose bending stiffness against mode l is
/// `stiffness[l]` times the continuum's ([`model_power`]); an empty
/// `stiffness` is the continuum.
pub fn fit_against(
    frames: &[(f64, Vec<f64>)],
    blocks: usize,
    l_min: usize,
    l_max: usize,
    kbt: f64,
    stiffness: &[f64],
) -> Result<Spectrum, FitError> {
    if l_min < 2 || l_max < l_min + 1 {
        return Err(FitError::Range { l_min, l_max });
    }
    let blocks = blocks.max(2);
    if frames.len() < blocks {
        return Err(FitError::TooFewFrames {
            frames: frames.len(),
            blocks,
        });
    }
    let per_block = frames.len() / blocks;
    let used = &frames[..per_block * blocks];
    let mean_radius = used.iter().map(|f| f.0).sum::<f64>() / used.len() as f64;
    let mut power = vec![0.0; l_max + 1];
    let mut power_error = vec![0.0; l_max + 1];
    for l in l_min..=l_max {
        let means: Vec<f64> = used
            .chunks(per_block)
            .map(|c| c.iter().map(|f| f.1[l]).sum::<f64>() / c.len() as f64)
            .collect();
        let mean = means.iter().sum::<f64>() / blocks as f64;
        let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (blocks - 1) as f64;
        power[l] = mean;
        power_error[l] = (var / blocks as f64).sqrt();
    }
    // 1/P_l = A x_l + B y_l, A = κ/k_BT, B = σR0²/k_BT; σ(1/P) = σ_P / P².
    let (mut sxx, mut sxy, mut syy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let rows: Vec<(f64, f64, f64, f64)> = (l_min..=l_max)
        .map(|l| {
            let lf = l as f64;
            let y = (lf - 1.0) * (lf + 2.0);
            let x = y * lf * (lf + 1.0) * stiffness.get(l).copied().unwrap_or(1.0);
            let z = 1.0 / power[l];
            let sz = power_error[l] / (power[l] * power[l]);
            (x, y, z, 1.0 / (sz * sz).max(f64::MIN_POSITIVE))
        })
        .collect();
    for &(x, y, z, w) in &rows {
        sxx += w * x * x;
        sxy += w * x * y;
        syy += w * y * y;
        sxz += w * x * z;
        syz += w * y * z;
    }
    let det = sxx * syy - sxy * sxy;
    if !(det.is_finite() && det > 0.0) {
        return Err(FitError::Degenerate);
    }
    let a = (syy * sxz - sxy * syz) / det;
    let b = (sxx * syz - sxy * sxz) / det;
    let chi2: f64 = rows
        .iter()
        .map(|&(x, y, z, w)| w * (z - a * x - b * y).powi(2))
        .sum();
    let dof = (rows.len() - 2).max(1) as f64;
    let scale = (chi2 / dof).max(1.0);
    let (var_a, var_b) = (syy / det * scale, sxx / det * scale);
    Ok(Spectrum {
        frames: used.len(),
        blocks,
        mean_radius,
        l_min,
        l_max,
        power,
        power_error,
        kappa: a * kbt,
        kappa_error: var_a.sqrt() * kbt,
        sigma: b * kbt / (mean_radius * mean_radius),
        sigma_error: var_b.sqrt() * kbt / (mean_radius * mean_radius),
        chi2_per_dof: chi2 / dof,
        kbt,
        stiffness: stiffness.to_vec(),
    })
}

impl Spectrum {
    /// The model's stiffness factor for mode l (1: the continuum).
    pub fn stiffness_of(&self, l: usize) -> f64 {
        self.stiffness.get(l).copied().unwrap_or(1.0)
    }
}
