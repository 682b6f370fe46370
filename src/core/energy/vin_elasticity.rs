//! The in-plane elasticity that V_in gives a mesh of fixed connectivity.
//!
//! A triangular central-force network with bonds of length ℓ, bond tension
//! τ = V′(ℓ) and bond stiffness k = V″(ℓ) has, per unit area
//! (`reference/fluid-membrane.md` §1.1 and §A; Seung & Nelson, PRA 38, 1005
//! (1988) for τ = 0):
//! - shear modulus μ = (√3/4)(k + 3τ/ℓ),
//! - 2-D bulk modulus B = (√3/2)(k − τ/ℓ),
//! - 2-D Young's modulus Y = 4Bμ/(B + μ).
//!
//! On a real mesh the bonds differ, so the moduli here are those of the
//! edge averages ⟨V″⟩ and ⟨V′/ℓ⟩ (a mean-field estimate; the twist probe in
//! the tests measures μ on the mesh within 15 % of it). V″ is the smooth
//! potential's (the piecewise-linear form's chords approximate it).
//!
//! What this elasticity weighs against bending is the Föppl-von Kármán
//! number γ = Y·A/(4πκ) = Y R0²/κ: above 1 the paper's model is an elastic
//! shell whose shape depends on the vesicle's size (in l̄), not only on its
//! reduced volume.

use crate::energy::vin::Segmentation;

/// Moduli of a V_in network (Ē/l̄²).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NetworkModuli {
    /// Shear modulus μ = (√3/4)(⟨V″⟩ + 3⟨V′/ℓ⟩).
    pub shear: f64,
    /// 2-D bulk (area) modulus B = (√3/2)(⟨V″⟩ − ⟨V′/ℓ⟩).
    pub bulk: f64,
    /// 2-D Young's modulus Y = 4Bμ/(B + μ).
    pub young: f64,
}

/// Step of the central difference that gives V″ from the exact slope (l̄).
const CURVATURE_STEP: f64 = 1e-5;

/// V″(ℓ) of the smooth potential (Ē/l̄²), by a central difference of its
/// exact slope.
pub fn stiffness(seg: &Segmentation, l: f64) -> f64 {
    let h = CURVATURE_STEP;
    (seg.exact_and_slope(l + h).1 - seg.exact_and_slope(l - h).1) / (2.0 * h)
}

/// The moduli of the network whose edges have `lengths` (l̄); zero for no
/// edges.
pub fn network_moduli(seg: &Segmentation, lengths: impl IntoIterator<Item = f64>) -> NetworkModuli {
    let (mut k, mut t, mut n) = (0.0, 0.0, 0usize);
    for l in lengths {
        k += stiffness(seg, l);
        t += seg.exact_and_slope(l).1 / l;
        n += 1;
    }
    if n == 0 {
        return NetworkModuli::default();
    }
    let (k, t) = (k / n as f64, t / n as f64);
    let s3 = 3f64.sqrt();
    let shear = s3 / 4.0 * (k + 3.0 * t);
    let bulk = s3 / 2.0 * (k - t);
    let young = if bulk + shear != 0.0 {
        4.0 * bulk * shear / (bulk + shear)
    } else {
        0.0
    };
    NetworkModuli { shear, bulk, young }
}

/// Föppl-von Kármán number γ = Y·A/(4πκ) (dimensionless) of a membrane of
/// area `area` (l̄²) and bending rigidity `kappa` (Ē).
pub fn foppl_von_karman(young: f64, area: f64, kappa: f64) -> f64 {
    young * area / (4.0 * std::f64::consts::PI * kappa)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::vin::VinParams;

    #[test]
    fn moduli_at_the_well_bottom_match_the_reference_table() {
        // reference/fluid-membrane.md §1.1: at ℓ = 1, V″ = 0.24, μ = 0.104,
        // B = 0.207, Y = 0.277 (Ē/l̄²); at 1.1: μ = 0.65, B = 1.12.
        let seg = Segmentation::new(VinParams::default());
        let m = network_moduli(&seg, [1.0]);
        assert!((m.shear - 0.104).abs() < 0.003, "{m:?}");
        assert!((m.bulk - 0.207).abs() < 0.005, "{m:?}");
        assert!((m.young - 0.277).abs() < 0.005, "{m:?}");
        let m = network_moduli(&seg, [1.1]);
        assert!((m.shear - 0.65).abs() < 0.02, "{m:?}");
        assert!((m.bulk - 1.12).abs() < 0.03, "{m:?}");
    }
}
