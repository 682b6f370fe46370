//! Shape metrics of a closed membrane in its principal frame: diameter,
//! thickness at the centre and maximal thickness, axisymmetry, and a
//! discocyte / stomatocyte / convex classification (paper Fig 3A).

use glam::DVec3;
use nalgebra::{Matrix3, SymmetricEigen};
use serde::Serialize;

/// Principal frame of a mesh: centroid and orthonormal axes sorted by
/// increasing second moment (`axes[0]` is the thinnest direction, the
/// symmetry axis of an oblate cell).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrincipalFrame {
    /// Area-weighted centroid (l̄).
    pub centroid: DVec3,
    /// Unit axes, thinnest first.
    pub axes: [DVec3; 3],
    /// Second moments along the axes (l̄²), increasing.
    pub moments: [f64; 3],
}

/// Principal frame from area-weighted vertex positions.
pub fn principal_frame(positions: &[DVec3], faces: &[[u32; 3]]) -> PrincipalFrame {
    let mut weights = vec![0.0; positions.len()];
    for f in faces {
        let [a, b, c] = [f[0] as usize, f[1] as usize, f[2] as usize];
        let area = 0.5
            * (positions[b] - positions[a])
                .cross(positions[c] - positions[a])
                .length();
        for v in [a, b, c] {
            weights[v] += area / 3.0;
        }
    }
    let total: f64 = weights.iter().sum();
    let centroid = positions
        .iter()
        .zip(&weights)
        .map(|(p, w)| *p * *w)
        .sum::<DVec3>()
        / total;
    let mut m = Matrix3::<f64>::zeros();
    for (p, w) in positions.iter().zip(&weights) {
        let d = *p - centroid;
        let v = nalgebra::Vector3::new(d.x, d.y, d.z);
        m += (v * v.transpose()) * (*w / total);
    }
    let eigen = SymmetricEigen::new(m);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| eigen.eigenvalues[i].total_cmp(&eigen.eigenvalues[j]));
    let axis = |i: usize| {
        let c = eigen.eigenvectors.column(i);
        DVec3::new(c[0], c[1], c[2]).normalize()
    };
    let mut axes = order.map(axis);
    // Right-handed frame.
    if axes[0].cross(axes[1]).dot(axes[2]) < 0.0 {
        axes[2] = -axes[2];
    }
    PrincipalFrame {
        centroid,
        axes,
        moments: order.map(|i| eigen.eigenvalues[i]),
    }
}

/// Shape class of an axisymmetric cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeClass {
    /// Both faces dimpled at the centre (biconcave).
    Discocyte,
    /// One face dimpled, the other bulging the same way (cup).
    Stomatocyte,
    /// No dimple.
    Convex,
}

/// Metrics of the shape in its principal frame (lengths in l̄).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ShapeMetrics {
    /// Largest distance from the symmetry axis, doubled.
    pub diameter: f64,
    /// Thickness along the axis at the centre (innermost 10 % of the radius).
    pub centre_height: f64,
    /// Largest thickness along the axis over the radius.
    pub max_height: f64,
    /// centre_height / max_height (< 1: dimpled).
    pub centre_to_max_height: f64,
    /// Ratio of the two larger second moments (1 = axisymmetric).
    pub axisymmetry: f64,
    /// The classification.
    pub class: ShapeClass,
}

/// Measures the shape: radial profile of the upper and lower surfaces along
/// the thinnest principal axis.
pub fn shape_metrics(positions: &[DVec3], faces: &[[u32; 3]]) -> ShapeMetrics {
    let frame = principal_frame(positions, faces);
    let local: Vec<(f64, f64)> = positions
        .iter()
        .map(|p| {
            let d = *p - frame.centroid;
            let z = d.dot(frame.axes[0]);
            let r = (d - z * frame.axes[0]).length();
            (r, z)
        })
        .collect();
    let radius = local.iter().map(|&(r, _)| r).fold(0.0, f64::max);
    const BINS: usize = 10;
    let mut top = [f64::NEG_INFINITY; BINS];
    let mut bottom = [f64::INFINITY; BINS];
    for &(r, z) in &local {
        let b = ((r / radius * BINS as f64) as usize).min(BINS - 1);
        top[b] = top[b].max(z);
        bottom[b] = bottom[b].min(z);
    }
    let filled: Vec<usize> = (0..BINS).filter(|&b| top[b].is_finite()).collect();
    let centre = filled.first().copied().unwrap_or(0);
    let centre_height = top[centre] - bottom[centre];
    let max_height = filled
        .iter()
        .map(|&b| top[b] - bottom[b])
        .fold(0.0, f64::max);
    let max_top = filled
        .iter()
        .map(|&b| top[b])
        .fold(f64::NEG_INFINITY, f64::max);
    let min_bottom = filled
        .iter()
        .map(|&b| bottom[b])
        .fold(f64::INFINITY, f64::min);
    // A face is dimpled when its centre lies 5 % of the thickness inside its rim.
    let dent = 0.05 * max_height;
    let top_dimpled = top[centre] < max_top - dent;
    let bottom_dimpled = bottom[centre] > min_bottom + dent;
    let class = match (top_dimpled, bottom_dimpled) {
        (true, true) => ShapeClass::Discocyte,
        (true, false) | (false, true) => ShapeClass::Stomatocyte,
        (false, false) => ShapeClass::Convex,
    };
    ShapeMetrics {
        diameter: 2.0 * radius,
        centre_height,
        max_height,
        centre_to_max_height: centre_height / max_height,
        axisymmetry: frame.moments[1] / frame.moments[2],
        class,
    }
}
