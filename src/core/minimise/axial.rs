//! Keeping an axisymmetric shape axisymmetric: the minimiser's steps made
//! orthogonal to the two quadrupolar deformations that break the symmetry
//! about an axis.
//!
//! Some branches of axisymmetric equilibria are saddles among all shapes:
//! the oblate branch of the vesicle shape diagram (Seifert, Berndl &
//! Lipowsky 1991) is unstable near v = 1 to the triaxial (l = 2, m = ±2)
//! deformation that leads to the prolate. A minimiser whose steps are large
//! in the long-wavelength modes (the Sobolev metric) leaves such a branch
//! for the prolate one; FIRE in the Euclidean metric stays near it only
//! because it is slow. With e₁, e₂ an orthonormal pair perpendicular to
//! the axis a, c the vertices' centroid and (u_i, w_i) = ((x_i − c)·e₁,
//! (x_i − c)·e₂), the two deformations are the gradients of the in-plane
//! quadrupole moments
//!
//! q₁ = Σ_i u_i² − w_i², q₂ = Σ_i 2 u_i w_i,
//!
//! ∇_i q₁ = 2(u_i e₁ − w_i e₂) and ∇_i q₂ = 2(w_i e₁ + u_i e₂): a stretch
//! along e₁ and a squeeze along e₂, and the same turned by 45°. The
//! minimiser removes their normal parts (what changes the shape) from
//! every step, jointly with the constraints' tangency, so that
//! ∇A·d = ∇V·d = 0 still hold: the shape's quadrupole is held to first
//! order, the vertices may still slide tangentially. The force
//! itself is left alone: convergence by the force tolerance still means a
//! stationary point of the unconstrained problem, so an axisymmetric
//! saddle is reported as one only when its force along these modes
//! vanishes, as it does by symmetry.

use glam::{DMat4, DVec3, DVec4};

/// The two symmetry-breaking deformations ∇q₁, ∇q₂ about `axis` at
/// `positions`, written into `out` (by vertex slot).
pub fn quadrupole_modes(positions: &[DVec3], axis: DVec3, out: &mut [Vec<DVec3>; 2]) {
    let a = axis.normalize();
    let e1 = a.any_orthonormal_vector();
    let e2 = a.cross(e1);
    let n = positions.len().max(1) as f64;
    let c = positions.iter().copied().sum::<DVec3>() / n;
    let [g1, g2] = out;
    g1.clear();
    g2.clear();
    for &x in positions {
        let (u, w) = ((x - c).dot(e1), (x - c).dot(e2));
        g1.push(2.0 * (u * e1 - w * e2));
        g2.push(2.0 * (w * e1 + u * e2));
    }
}

fn dot(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x.dot(*y)).sum()
}

/// Removes from `direction` a combination of `columns` such that it ends
/// orthogonal to every row: `pairs` are (row, column) pairs, at most four
/// (the active constraints' gradients with the columns the step moves
/// along to keep them, then the quadrupole modes with themselves). With
/// R the rows and U the columns, d ← d − U (RᵀU)⁻¹ Rᵀd. A singular system
/// (a mode that vanishes, e.g. on a shape with no extent across the axis)
/// leaves `direction` unchanged.
pub fn remove_along(direction: &mut [DVec3], pairs: &[(&[DVec3], &[DVec3])]) {
    assert!(pairs.len() <= 4, "at most four rows");
    let mut m = DMat4::IDENTITY;
    let mut r = DVec4::ZERO;
    for (i, (row, _)) in pairs.iter().enumerate() {
        r[i] = dot(row, direction);
        for (j, (_, column)) in pairs.iter().enumerate() {
            // DMat4 is column-major: entry (i, j) is column j, row i.
            m.col_mut(j)[i] = dot(row, column);
        }
    }
    if m.determinant().abs() <= f64::MIN_POSITIVE || !m.determinant().is_finite() {
        return;
    }
    let mu = m.inverse() * r;
    for (j, (_, column)) in pairs.iter().enumerate() {
        for (d, u) in direction.iter_mut().zip(column.iter()) {
            *d -= mu[j] * *u;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random cloud's direction ends orthogonal to the two modes and to
    /// a constraint row held along its own column.
    #[test]
    fn the_direction_ends_orthogonal_to_every_row() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(7);
        let mut next = || rng.random::<f64>() - 0.5;
        let mut random = |k: usize| -> Vec<DVec3> {
            (0..k).map(|_| DVec3::new(next(), next(), next())).collect()
        };
        let positions = random(50);
        let row = random(50);
        let column = random(50);
        let mut d = random(50);
        let mut modes = [Vec::new(), Vec::new()];
        quadrupole_modes(&positions, DVec3::new(0.3, -0.2, 1.0), &mut modes);
        remove_along(
            &mut d,
            &[
                (&row, &column),
                (&modes[0], &modes[0]),
                (&modes[1], &modes[1]),
            ],
        );
        let scale = dot(&d, &d).sqrt();
        for r in [&row, &modes[0], &modes[1]] {
            assert!(dot(r, &d).abs() < 1e-12 * scale * dot(r, r).sqrt());
        }
    }

    /// The modes are the first-order changes of q₁ and q₂ (central
    /// differences).
    #[test]
    fn the_modes_are_the_quadrupole_gradients() {
        let positions: Vec<DVec3> = (0..20)
            .map(|i| {
                let t = i as f64;
                DVec3::new((1.3 * t).sin() * 2.0, (0.7 * t).cos(), 0.1 * t)
            })
            .collect();
        let axis = DVec3::new(0.0, 0.2, 1.0);
        let a = axis.normalize();
        let e1 = a.any_orthonormal_vector();
        let e2 = a.cross(e1);
        let q = |x: &[DVec3]| -> [f64; 2] {
            let c = x.iter().copied().sum::<DVec3>() / x.len() as f64;
            x.iter().fold([0.0, 0.0], |[s, t], &p| {
                let (u, w) = ((p - c).dot(e1), (p - c).dot(e2));
                [s + u * u - w * w, t + 2.0 * u * w]
            })
        };
        let mut modes = [Vec::new(), Vec::new()];
        quadrupole_modes(&positions, axis, &mut modes);
        let h = 1e-6;
        for v in [0, 7, 19] {
            for k in 0..3 {
                let mut plus = positions.clone();
                let mut minus = positions.clone();
                plus[v][k] += h;
                minus[v][k] -= h;
                let (qp, qm) = (q(&plus), q(&minus));
                for m in 0..2 {
                    let fd = (qp[m] - qm[m]) / (2.0 * h);
                    assert!((fd - modes[m][v][k]).abs() < 1e-6, "{fd} {:?}", modes[m][v]);
                }
            }
        }
    }
}
