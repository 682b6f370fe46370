//! Contact curvature of a membrane adhered to a substrate: the curvature of
//! the free membrane where it leaves the substrate, which Seifert and
//! Lipowsky's contact condition (Phys. Rev. A 42, 4768, 1990) fixes at
//! √(2W/κ) for a contact potential of vanishing range.
//!
//! Method. Every vertex i has a height z_i above the substrate (its
//! distance, [`WallShape::distance`]) and a tilt ψ_i, the angle between its
//! outward normal n_i (area-weighted face normals) and the direction −∇d
//! into the substrate: cos ψ_i = −n_i·∇d. On the bound part ψ = 0; along
//! the steepest path up from the contact line dz/ds = sin ψ and the
//! curvature is c = dψ/ds, so dz/dψ = sin ψ / c(ψ). With the radius of
//! curvature 1/c(ψ) = b₀ + b₁ψ near the contact line this integrates to
//!
//! z(ψ) = z₀ + b₀ (1 − cos ψ) + b₁ (sin ψ − ψ cos ψ),
//!
//! which is linear in (z₀, b₀, b₁): a least-squares fit over the vertices
//! of the free membrane near the contact line (z ≥ `from_height`, 0 < ψ ≤
//! `max_tilt`) gives the contact curvature c = 1/b₀, the curvature
//! extrapolated to the point where the free profile is tangent to the
//! substrate. Nothing in it needs an axis: every vertex near the contact
//! line is on one such path, and the condition holds all along the line.
//!
//! Why extrapolate in ψ and start above the potential's range ρ: for a
//! contact potential U(z) the first integral of the profile's shape
//! equation gives κc²/2 = W + (terms that vanish at ψ = 0) outside the
//! range, whatever ρ is; the curvature measured inside the range instead
//! follows W(1 − φ(z)) and goes to 0 at the substrate. So the fit takes
//! `from_height` = ρ (the adhesion recorder's choice) and reads the free
//! membrane's curvature law at ψ = 0.
//!
//! A cheap per-frame estimate, not the number to quote: its height offset
//! z₀ and its curvature are nearly degenerate over tilts that start above
//! the range, and it reads high on coarse meshes (1.18 × √(2W/κ) at
//! h = 1/2 and W R0²/κ = 5.94, where the fit to the continuum vesicle
//! reads 1.047). The study's adhesion problems measure the contact
//! curvature against the continuum adhered vesicle
//! (`crate::analysis::axisymmetric::contact_fit`, docs/adhesion.md).
//!
//! Units: heights in l̄, curvature in 1/l̄, angles in radians.

use crate::energy::wall::WallShape;
use glam::DVec3;

/// Default largest tilt of the vertices in the fit (rad; 1 rad ≈ 57°):
/// far enough up the contact region that a fine mesh gives tens of
/// vertices, close enough that the radius of curvature is near linear in ψ.
pub const MAX_TILT: f64 = 1.0;

/// Fewest vertices for a fit.
const MIN_VERTICES: usize = 6;

/// The contact curvature and the fit behind it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactCurvature {
    /// c = 1/b₀, the free membrane's curvature at the contact line (1/l̄).
    pub curvature: f64,
    /// b₁, how the radius of curvature grows with the tilt (l̄/rad).
    pub slope: f64,
    /// z₀, the height at which the fitted free profile is tangent to the
    /// substrate (l̄).
    pub contact_height: f64,
    /// Vertices in the fit.
    pub vertices: usize,
    /// Root-mean-square residual of the fit in height (l̄).
    pub rms: f64,
}

/// Outward vertex normals (area-weighted face normals, unit length; zero
/// for a vertex with no face).
pub fn vertex_normals(positions: &[DVec3], faces: &[[u32; 3]]) -> Vec<DVec3> {
    let mut normals = vec![DVec3::ZERO; positions.len()];
    for f in faces {
        let [a, b, c] = f.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in f {
            normals[i as usize] += n;
        }
    }
    normals.iter().map(|n| n.normalize_or_zero()).collect()
}

/// The contact curvature of the membrane `positions`/`faces` on `shape`,
/// fitted over the vertices at least `from_height` above it with a tilt in
/// (0, `max_tilt`] (see the module header). `None` with fewer than six such
/// vertices, a singular fit, or a radius of curvature b₀ ≤ 0.
pub fn contact_curvature(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    shape: &WallShape,
    from_height: f64,
    max_tilt: f64,
) -> Option<ContactCurvature> {
    let normals = vertex_normals(positions, faces);
    // Normal equations of z = z₀ + b₀ u + b₁ v, u = 1 − cos ψ,
    // v = sin ψ − ψ cos ψ.
    let mut m = [[0.0; 3]; 3];
    let mut rhs = [0.0; 3];
    let mut samples = Vec::new();
    for (&x, &n) in positions.iter().zip(&normals) {
        let (z, gradient) = shape.distance(x);
        let cos_psi = (-n.dot(gradient)).clamp(-1.0, 1.0);
        let psi = cos_psi.acos();
        if z < from_height || psi <= 0.0 || psi > max_tilt || n == DVec3::ZERO {
            continue;
        }
        let row = [1.0, 1.0 - cos_psi, psi.sin() - psi * cos_psi];
        for (j, mj) in m.iter_mut().enumerate() {
            for (k, mjk) in mj.iter_mut().enumerate() {
                *mjk += row[j] * row[k];
            }
            rhs[j] += row[j] * z;
        }
        samples.push((row, z));
    }
    if samples.len() < MIN_VERTICES {
        return None;
    }
    let [z0, b0, b1] = solve3(m, rhs)?;
    if b0.is_nan() || b0 <= 0.0 {
        return None;
    }
    let residual: f64 = samples
        .iter()
        .map(|(row, z)| (z0 + b0 * row[1] + b1 * row[2] - z).powi(2))
        .sum();
    Some(ContactCurvature {
        curvature: 1.0 / b0,
        slope: b1,
        contact_height: z0,
        vertices: samples.len(),
        rms: (residual / samples.len() as f64).sqrt(),
    })
}

/// Solves the 3×3 system m x = rhs by Gaussian elimination with partial
/// pivoting; `None` if it is singular.
fn solve3(mut m: [[f64; 3]; 3], mut rhs: [f64; 3]) -> Option<[f64; 3]> {
    let scale = m.iter().flatten().fold(0.0_f64, |s, v| s.max(v.abs()));
    for col in 0..3 {
        let pivot = (col..3).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if m[pivot][col].abs() <= 1e-12 * scale {
            return None;
        }
        m.swap(col, pivot);
        rhs.swap(col, pivot);
        for row in col + 1..3 {
            let factor = m[row][col] / m[col][col];
            for k in col..3 {
                m[row][k] -= factor * m[col][k];
            }
            rhs[row] -= factor * rhs[col];
        }
    }
    let mut x = [0.0; 3];
    for row in (0..3).rev() {
        let tail: f64 = (row + 1..3).map(|k| m[row][k] * x[k]).sum();
        x[row] = (rhs[row] - tail) / m[row][row];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed surface of revolution about z that lies flat on z = 0 out
    /// to radius `r_c`, leaves it with curvature 1/b₀ and a radius of
    /// curvature b₀ + b₁ψ, turns up to ψ = π and is closed by a flat lid:
    /// `rings` meridian steps, `segments` around.
    fn adhered_profile(r_c: f64, b0: f64, b1: f64, rings: usize, segments: usize) -> Mesh {
        // The meridian: a bound disc, then the curved part by ψ.
        let mut profile = vec![(0.0, 0.0)];
        let bound = rings / 4;
        for k in 1..=bound {
            profile.push((r_c * k as f64 / bound as f64, 0.0));
        }
        let steps = rings;
        let (mut r, mut z, mut psi) = (r_c, 0.0, 0.0);
        let dpsi = std::f64::consts::PI / steps as f64;
        for _ in 0..steps {
            // Midpoint rule on dr/dψ = cos ψ (b₀ + b₁ψ), dz/dψ = sin ψ (…).
            for _ in 0..50 {
                let mid = psi + dpsi / 100.0;
                let radius = b0 + b1 * mid;
                r += mid.cos() * radius * dpsi / 50.0;
                z += mid.sin() * radius * dpsi / 50.0;
                psi += dpsi / 50.0;
            }
            profile.push((r, z));
        }
        let lid = (r / 1.0).ceil() as usize;
        for k in 1..lid {
            profile.push((r * (1.0 - k as f64 / lid as f64), z));
        }
        profile.push((0.0, z));
        revolve(&profile, segments)
    }

    type Mesh = (Vec<DVec3>, Vec<[u32; 3]>);

    /// Triangulates the surface of revolution of `profile` (first and last
    /// points on the axis), faces outward.
    fn revolve(profile: &[(f64, f64)], segments: usize) -> Mesh {
        let mut positions = vec![DVec3::new(0.0, 0.0, profile[0].1)];
        let rings = profile.len() - 2;
        for (k, &(r, z)) in profile[1..=rings].iter().enumerate() {
            let twist = 0.5 * (k % 2) as f64;
            for j in 0..segments {
                let t = std::f64::consts::TAU * (j as f64 + twist) / segments as f64;
                positions.push(DVec3::new(r * t.cos(), r * t.sin(), z));
            }
        }
        let top = positions.len() as u32;
        positions.push(DVec3::new(0.0, 0.0, profile[rings + 1].1));
        let s = segments as u32;
        let at = |ring: usize, j: u32| 1 + ring as u32 * s + j % s;
        let mut faces = Vec::new();
        for j in 0..s {
            faces.push([0, at(0, j + 1), at(0, j)]);
            faces.push([top, at(rings - 1, j), at(rings - 1, j + 1)]);
        }
        for ring in 0..rings - 1 {
            for j in 0..s {
                let (a, b) = (at(ring, j), at(ring, j + 1));
                let (c, d) = (at(ring + 1, j), at(ring + 1, j + 1));
                if ring % 2 == 0 {
                    faces.push([a, b, c]);
                    faces.push([b, d, c]);
                } else {
                    faces.push([a, d, c]);
                    faces.push([a, b, d]);
                }
            }
        }
        (positions, faces)
    }

    fn plane() -> WallShape {
        WallShape::Plane {
            point: (0.0, 0.0, 0.0),
            normal: (0.0, 0.0, 1.0),
        }
    }

    #[test]
    fn the_fit_recovers_a_known_contact_curvature() {
        // Radius of curvature 1.5 l̄ at the contact line, growing by 0.5 l̄
        // per radian of tilt (the lid's radius is then 2 l̄), on a mesh of
        // about 0.1 l̄.
        let (positions, faces) = adhered_profile(3.0, 1.5, 0.5, 80, 240);
        let volume: f64 = faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        assert!(volume > 0.0, "faces must point outward");
        let fit = contact_curvature(&positions, &faces, &plane(), 0.05, MAX_TILT).unwrap();
        assert!(
            (fit.curvature * 1.5 - 1.0).abs() < 0.01,
            "{fit:?} against 1/1.5"
        );
        assert!((fit.slope - 0.5).abs() < 0.05, "{fit:?}");
        assert!(
            fit.contact_height.abs() < 0.01 && fit.vertices > 100,
            "{fit:?}"
        );
    }

    #[test]
    fn a_membrane_off_the_substrate_or_too_few_vertices_give_none() {
        let (positions, faces) = adhered_profile(3.0, 1.5, 0.0, 8, 6);
        assert!(contact_curvature(&positions, &faces, &plane(), 0.05, 0.1).is_none());
        assert!(
            solve3(
                [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]],
                [1.0; 3]
            )
            .is_none()
        );
        let x = solve3(
            [[0.0, 2.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 4.0]],
            [2.0, 3.0, 8.0],
        );
        assert_eq!(x, Some([3.0, 1.0, 2.0]));
    }
}
