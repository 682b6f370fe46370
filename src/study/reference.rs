//! Exact answers of the study's reference problems, computed without the
//! engine: a sphere's bending energy 8πκ, a spheroid's by 1-D quadrature,
//! and the axisymmetric minimiser of [`crate::analysis::axisymmetric`].

use std::f64::consts::PI;

/// A reference value and its estimated error (same unit).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Value {
    /// The value.
    pub value: f64,
    /// Its estimated absolute error (0 for a closed form).
    pub error: f64,
}

/// Bending energy (κ/2)∫(2H)² dA of a sphere: 8πκ, whatever its radius.
pub fn sphere_bending(kappa: f64) -> Value {
    Value {
        value: 8.0 * PI * kappa,
        error: 0.0,
    }
}

/// Bending energy (κ/2)∫(2H)² dA of the spheroid with equatorial semi-axis
/// `a` and polar semi-axis `c` (l̄), by composite Simpson quadrature over the
/// polar parameter θ of (a sin θ cos φ, a sin θ sin φ, c cos θ). With
/// w = √(a² cos²θ + c² sin²θ), the principal curvatures are a c / w³
/// (meridian) and c / (a w) (parallel), and dA = 2π a sin θ w dθ. The error
/// is the difference between n and 2n intervals.
pub fn spheroid_bending(a: f64, c: f64, kappa: f64) -> Value {
    let integrand = |t: f64| {
        let (s, co) = t.sin_cos();
        let w = (a * a * co * co + c * c * s * s).sqrt();
        let two_h = a * c / (w * w * w) + c / (a * w);
        PI * kappa * two_h * two_h * a * s * w
    };
    let simpson = |n: usize| {
        let h = PI / n as f64;
        let mut sum = integrand(0.0) + integrand(PI);
        for i in 1..n {
            sum += integrand(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        sum * h / 3.0
    };
    let coarse = simpson(4000);
    let fine = simpson(8000);
    Value {
        value: fine,
        error: (fine - coarse).abs(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spheroid_with_equal_axes_is_a_sphere() {
        for r in [0.5, 1.0, 7.0] {
            let e = spheroid_bending(r, r, 2.0);
            assert!((e.value - 16.0 * PI).abs() < 1e-10, "{e:?}");
            assert!(e.error < 1e-10);
        }
    }

    #[test]
    fn spheroid_energy_is_scale_free_and_grows_with_elongation() {
        let e1 = spheroid_bending(5.0, 8.0, 1.0).value;
        let e2 = spheroid_bending(10.0, 16.0, 1.0).value;
        assert!((e1 - e2).abs() < 1e-9 * e1);
        let e3 = spheroid_bending(5.0, 12.0, 1.0).value;
        assert!(8.0 * PI < e1 && e1 < e3, "{e1} {e3}");
        // Oblate spheroids bend more than the sphere too.
        assert!(spheroid_bending(8.0, 5.0, 1.0).value > 8.0 * PI);
    }

    #[test]
    fn the_quadrature_agrees_with_an_independent_surface_sum() {
        // Midpoint sum over (θ, φ) of (κ/2)(k1 + k2)² |x_θ × x_φ| with the
        // curvatures from the first and second fundamental forms.
        let (a, c) = (5.0, 8.0);
        let n = 2000;
        let mut sum = 0.0;
        for i in 0..n {
            let t = (i as f64 + 0.5) * PI / n as f64;
            let (s, co) = t.sin_cos();
            // Per unit φ: x_θ = (a cos θ, 0, −c sin θ) rotated, x_φ = (0, a sin θ, 0).
            let e = a * a * co * co + c * c * s * s; // |x_θ|²
            let g = a * a * s * s; // |x_φ|²
            // Unit normal (c sin θ, 0, a cos θ)/√e; L = n·x_θθ, N = n·x_φφ.
            let l = a * c / e.sqrt();
            let nn = a * c * s * s / e.sqrt();
            let two_h = l / e + nn / g;
            sum += 0.5 * two_h * two_h * (e * g).sqrt() * (PI / n as f64) * 2.0 * PI;
        }
        let q = spheroid_bending(a, c, 1.0).value;
        assert!((sum - q).abs() < 1e-5 * q, "{sum} {q}");
    }
}
