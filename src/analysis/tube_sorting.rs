//! The continuum reference for curvature sorting into a tube: a long
//! cylindrical tether of radius R held at a constant area coefficient σ,
//! carrying one protein species bound from a bulk at chemical potential μ
//! (Ē per protein), with the species' free energy per area
//! f(φ, C) = κ/2 (C − c φ)² + σ + (k_BT/a_p)[φ ln φ + (1 − φ) ln(1 − φ)]
//! (C = 1/R the total curvature, c the coupling; no rigidity change or
//! interaction). A flat membrane at the same μ holds φ_v with
//! μ = κ a_p c² φ_v + k_BT ln(φ_v/(1 − φ_v)) ([`reservoir_potential`]).
//!
//! Stationarity of the tube's grand potential in R, in its length and in
//! φ_t (`../shared/reference/proteins.md` §2), with X = 1/R − c φ_t:
//! - κX²/2 = σ − Π_t, Π_t = −(k_BT/a_p) ln(1 − φ_t) the tube's protein pressure;
//! - the axial force f = 2πκX;
//! - μ = −a_p κ c X + k_BT ln(φ_t/(1 − φ_t)), one equation in φ_t whose left
//!   side is fixed and whose right side rises with φ_t for c ≥ 0 (for c < 0
//!   as well: X falls as φ_t rises), so its root is unique and bisection
//!   finds it.
//!
//! Limits: φ → 0 gives Derényi-Jülicher-Prost, R0 = √(κ/2σ) and
//! f0 = 2π√(2σκ); dilute sorting φ_t/φ_v → exp(a_p κ c/(k_BT R0)); at weak
//! coupling and fixed reservoir tension Σ = σ − Π_v − κc²φ_v²/2, the force
//! falls as f ≈ 2π√(2κΣ) − 2πκcφ_v. More precisely, in the dilute limit at
//! fixed Σ, f − f0 = −2πκc φ_v (e^E − 1)/E with E = a_p κ c/(k_BT R0) the
//! sorting exponent (the tube's extra proteins lower its tension), which is
//! the classic slope as E → 0.

/// A tube's setting (natural units: Ē, l̄).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TubeSetting {
    /// Bending rigidity κ (Ē).
    pub kappa: f64,
    /// The area coefficient σ of the energy (Ē/l̄²).
    pub sigma: f64,
    /// k_BT of the mixing entropy (Ē).
    pub temperature: f64,
    /// Area per protein a_p (l̄²).
    pub area_per_protein: f64,
    /// The spontaneous-curvature coupling c (1/l̄): C0 = c φ.
    pub coupling: f64,
    /// The bulk's chemical potential μ (Ē per protein).
    pub chemical_potential: f64,
}

impl TubeSetting {
    /// This setting bound at the chemical potential of a flat membrane at
    /// the fraction `phi_v` ([`reservoir_potential`]).
    pub fn bound_at(mut self, phi_v: f64) -> Self {
        self.chemical_potential = reservoir_potential(&self, phi_v);
        self
    }
}

/// The stationary tube.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SortedTube {
    /// The tube's fraction φ_t.
    pub fraction: f64,
    /// Its radius R (l̄).
    pub radius: f64,
    /// The axial force f that holds it (Ē/l̄).
    pub force: f64,
}

/// Why a setting has no stationary tube.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TubeSortingError {
    /// A parameter is not positive (κ, σ, k_BT, a_p) or not finite.
    #[error("{0} must be positive and finite")]
    Invalid(&'static str),
}

/// μ (Ē per protein) of a flat membrane at fraction `phi_v` in `setting`
/// (its `chemical_potential` is ignored).
pub fn reservoir_potential(setting: &TubeSetting, phi_v: f64) -> f64 {
    let s = setting;
    s.kappa * s.area_per_protein * s.coupling * s.coupling * phi_v
        + s.temperature * (phi_v / (1.0 - phi_v)).ln()
}

/// The reservoir tension Σ = σ − Π_v − κc²φ_v²/2 (Ē/l̄²) of a flat
/// membrane at `phi_v`: what a pipette holding it would measure.
pub fn reservoir_tension(setting: &TubeSetting, phi_v: f64) -> f64 {
    let s = setting;
    s.sigma + s.temperature / s.area_per_protein * (1.0 - phi_v).ln()
        - 0.5 * s.kappa * s.coupling * s.coupling * phi_v * phi_v
}

/// The stationary tube of `setting`, to round-off.
pub fn solve(setting: &TubeSetting) -> Result<SortedTube, TubeSortingError> {
    let s = setting;
    for (value, name) in [
        (s.kappa, "kappa"),
        (s.sigma, "sigma"),
        (s.temperature, "temperature"),
        (s.area_per_protein, "area_per_protein"),
    ] {
        if !(value > 0.0 && value.is_finite()) {
            return Err(TubeSortingError::Invalid(name));
        }
    }
    if !(s.coupling.is_finite() && s.chemical_potential.is_finite()) {
        return Err(TubeSortingError::Invalid("coupling and chemical_potential"));
    }
    let pressure_scale = s.temperature / s.area_per_protein;
    // X(φ) = √(2(σ + (k_BT/a_p) ln(1 − φ))/κ), real while φ < φ_max.
    let x_of = |phi: f64| (2.0 * (s.sigma + pressure_scale * (-phi).ln_1p()) / s.kappa).sqrt();
    let excess = |phi: f64| {
        -s.area_per_protein * s.kappa * s.coupling * x_of(phi)
            + s.temperature * (phi / (1.0 - phi)).ln()
            - s.chemical_potential
    };
    // Bracket in ln φ: from φ = 1e-300 to where the pressure eats σ.
    let phi_max = -(-s.sigma / pressure_scale).exp_m1();
    let (mut lo, mut hi) = (f64::MIN_POSITIVE.ln(), phi_max.ln());
    for _ in 0..4000 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if excess(mid.exp()) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let fraction = (0.5 * (lo + hi)).exp();
    let x = x_of(fraction);
    Ok(SortedTube {
        fraction,
        radius: 1.0 / (s.coupling * fraction + x),
        force: 2.0 * std::f64::consts::PI * s.kappa * x,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The bundled tether's tube: κ = 1, σ = 0.114544 (R0 = 2.0893,
    /// f0 = 3.0073), k_BT = 0.1.
    fn setting(a_p: f64, c: f64, phi_v: f64) -> TubeSetting {
        TubeSetting {
            kappa: 1.0,
            sigma: 0.114544,
            temperature: 0.1,
            area_per_protein: a_p,
            coupling: c,
            chemical_potential: 0.0,
        }
        .bound_at(phi_v)
    }

    fn djp(s: &TubeSetting) -> (f64, f64) {
        (
            (s.kappa / (2.0 * s.sigma)).sqrt(),
            2.0 * PI * (2.0 * s.sigma * s.kappa).sqrt(),
        )
    }

    #[test]
    fn the_stationarity_conditions_hold() {
        for (a_p, c, phi_v) in [(0.836, 0.5, 0.01), (2.09, 0.5, 0.01), (0.836, -0.5, 0.05)] {
            let s = setting(a_p, c, phi_v);
            let t = solve(&s).unwrap();
            let x = 1.0 / t.radius - c * t.fraction;
            let pressure = -s.temperature / a_p * (1.0 - t.fraction).ln();
            assert!((0.5 * s.kappa * x * x - (s.sigma - pressure)).abs() < 1e-14);
            assert!((t.force - 2.0 * PI * s.kappa * x).abs() < 1e-14);
            let mu =
                -a_p * s.kappa * c * x + s.temperature * (t.fraction / (1.0 - t.fraction)).ln();
            assert!((mu - s.chemical_potential).abs() < 1e-13, "{mu}");
        }
    }

    #[test]
    fn without_proteins_the_tube_is_derenyi_julicher_prost() {
        let s = setting(0.836, 0.5, 1e-12);
        let t = solve(&s).unwrap();
        let (r0, f0) = djp(&s);
        assert!((t.radius / r0 - 1.0).abs() < 1e-10 && (t.force / f0 - 1.0).abs() < 1e-10);
        // No coupling: the tube holds the flat membrane's fraction.
        let s = setting(0.836, 0.0, 0.02);
        let t = solve(&s).unwrap();
        assert!((t.fraction / 0.02 - 1.0).abs() < 1e-12, "{}", t.fraction);
    }

    #[test]
    fn dilute_sorting_is_the_boltzmann_factor() {
        for c in [0.5, -0.5] {
            let s = setting(0.836, c, 1e-9);
            let t = solve(&s).unwrap();
            let (r0, _) = djp(&s);
            let exponent = 0.836 * s.kappa * c / (s.temperature * r0);
            assert!(((t.fraction / 1e-9) / exponent.exp() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn crowding_caps_strong_sorting() {
        // Sorting exponent 5: the dilute factor e⁵ = 148 is capped at 44.8,
        // the tube 25 % thinner and its force 13 % lower.
        let s = setting(2.09, 0.5, 0.01);
        let t = solve(&s).unwrap();
        let (r0, f0) = djp(&s);
        assert!((t.fraction / 0.01 - 44.84).abs() < 0.01, "{}", t.fraction);
        assert!((t.radius / r0 - 0.7489).abs() < 1e-4 && (t.force / f0 - 0.8669).abs() < 1e-4);
    }

    #[test]
    fn the_force_falls_with_the_reservoir_fraction_at_fixed_reservoir_tension() {
        // Dilute, at fixed Σ: f − f0 = −2πκc φ_v (e^E − 1)/E, E the sorting
        // exponent, so the slope tends to the classic −2πκc at weak coupling.
        let (a_p, tension) = (0.836, 0.114544);
        for c in [0.05, 0.005] {
            let force = |phi_v: f64| {
                let mut s = setting(a_p, c, phi_v);
                s.sigma += tension - reservoir_tension(&s, phi_v);
                let s = s.bound_at(phi_v);
                solve(&s).unwrap().force
            };
            let s = setting(a_p, c, 0.0);
            let exponent = a_p * s.kappa * c / (s.temperature * djp(&s).0);
            let dphi = 1e-6;
            let slope = (force(2.0 * dphi) - force(dphi)) / dphi;
            let expected = -2.0 * PI * s.kappa * c * exponent.exp_m1() / exponent;
            assert!(
                (slope / expected - 1.0).abs() < 1e-4,
                "{slope} against {expected}"
            );
            if c == 0.005 {
                assert!((slope / (-2.0 * PI * c) - 1.0).abs() < 0.011, "{slope}");
            }
        }
    }

    #[test]
    fn bad_settings_are_refused() {
        let mut s = setting(0.836, 0.5, 0.01);
        s.sigma = 0.0;
        assert_eq!(solve(&s), Err(TubeSortingError::Invalid("sigma")));
    }
}
