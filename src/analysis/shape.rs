//! Shape metrics of a closed membrane in its principal frame: diameter,
//! thickness at the centre and maximal thickness, axisymmetry, and a
//! discocyte / stomatocyte / convex / prolate classification (paper Fig 3A).

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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeClass {
    /// Both faces dimpled at the centre (biconcave).
    Discocyte,
    /// One face dimpled, the other bulging the same way (cup).
    Stomatocyte,
    /// No dimple.
    Convex,
    /// Elongated along its symmetry axis: the largest second moment is the
    /// unique one (more than 10 % above the middle one, which is closer to
    /// the smallest), as on the prolate branch of vesicle shapes. The
    /// dimple measures along the thinnest axis mean nothing for it.
    Prolate,
}

/// The largest second moment must exceed the middle one by this factor for
/// a shape to be [`ShapeClass::Prolate`].
const PROLATE_ELONGATION: f64 = 1.1;

/// Metrics of the shape in its principal frame (lengths in l̄).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct ShapeMetrics {
    /// Largest distance from the symmetry axis, doubled.
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub diameter: f64,
    /// Thickness along the axis at the centre (innermost 10 % of the radius).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub centre_height: f64,
    /// Largest thickness along the axis over the radius.
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub max_height: f64,
    /// centre_height / max_height (< 1: dimpled).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub centre_to_max_height: f64,
    /// Ratio of the two larger second moments (1 = axisymmetric).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
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
    let [m0, m1, m2] = frame.moments;
    let prolate = m2 > PROLATE_ELONGATION * m1 && m2 - m1 > m1 - m0;
    let class = match (top_dimpled, bottom_dimpled) {
        _ if prolate => ShapeClass::Prolate,
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

/// Thicknesses of a closed mesh measured on its surface, not at its
/// vertices: lines parallel to the thinnest principal axis are intersected
/// with the faces, and the distance between the outermost crossings is the
/// thickness there (used against the axisymmetric reference).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AxialThickness {
    /// Largest distance of a vertex from the axis, doubled (l̄).
    pub diameter: f64,
    /// Thickness along the axis itself (l̄; NaN if the axis misses the
    /// mesh).
    pub centre: f64,
    /// Largest thickness over the distance from the axis, each the mean
    /// over 16 directions around it (l̄).
    pub max: f64,
}

/// Parameters t where the line o + t d crosses the faces.
fn line_crossings(positions: &[DVec3], faces: &[[u32; 3]], o: DVec3, d: DVec3) -> Vec<f64> {
    let mut hits = Vec::new();
    for f in faces {
        let [a, b, c] = f.map(|i| positions[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-14 {
            continue;
        }
        let s = o - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        // A little slack, so that a line through a vertex or along an edge
        // (icospheres have vertices on their axes) still hits.
        const SLACK: f64 = 1e-9;
        if u >= -SLACK && v >= -SLACK && u + v <= 1.0 + SLACK {
            hits.push(e2.dot(q) / det);
        }
    }
    hits
}

/// See [`AxialThickness`]; 200 radii from the axis to the rim, 16
/// directions each.
pub fn axial_thickness(positions: &[DVec3], faces: &[[u32; 3]]) -> AxialThickness {
    const RADII: usize = 200;
    const DIRECTIONS: usize = 16;
    let frame = principal_frame(positions, faces);
    let [n, e1, e2] = frame.axes;
    let radius = positions
        .iter()
        .map(|p| {
            let d = *p - frame.centroid;
            (d - d.dot(n) * n).length()
        })
        .fold(0.0, f64::max);
    let thickness = |o: DVec3| {
        let hits = line_crossings(positions, faces, o, n);
        let lo = hits.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = hits.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (hits.len() >= 2).then_some(hi - lo)
    };
    // No crossing at the centre (e.g. a shape that is not closed around its
    // axis): not measurable.
    let centre = thickness(frame.centroid).unwrap_or(f64::NAN);
    let mut max = if centre.is_finite() { centre } else { 0.0 };
    for k in 1..RADII {
        let rho = radius * k as f64 / RADII as f64;
        let mut sum = 0.0;
        let mut all = true;
        for j in 0..DIRECTIONS {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / DIRECTIONS as f64;
            let o = frame.centroid + rho * (phi.cos() * e1 + phi.sin() * e2);
            match thickness(o) {
                Some(t) => sum += t,
                None => all = false,
            }
        }
        if all {
            max = max.max(sum / DIRECTIONS as f64);
        }
    }
    AxialThickness {
        diameter: 2.0 * radius,
        centre,
        max,
    }
}

#[cfg(test)]
mod axial_tests {
    use super::*;

    #[test]
    fn a_spheroid_has_its_axes_as_thicknesses() {
        let mesh = crate::mesh::ellipsoid(5, [8.0, 8.0, 3.0], 0.0, 1);
        let t = axial_thickness(&mesh.positions, &mesh.faces);
        assert!((t.diameter - 16.0).abs() < 1e-9, "{t:?}");
        // Chords of the faces lie inside the surface: within 0.2 % at level 5.
        assert!((t.centre - 6.0).abs() < 0.012, "{t:?}");
        assert!((t.max - 6.0).abs() < 0.012, "{t:?}");
    }
}
