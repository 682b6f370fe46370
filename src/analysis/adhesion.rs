//! An adhered vesicle against the continuum adhered vesicle of the same
//! area, reduced volume, κ and W: the report of
//! [`crate::analysis::axisymmetric::contact_fit`], shared by the study's
//! `Adhesion` problems and every run's `summary.json` (the scene gives the
//! substrate and κ: [`crate::scene::Scene::adhesion_substrate`]).

use crate::analysis::axisymmetric::contact_fit::{
    ContactFitError, ContactFitInput, compare_with_continuum, fit_contact_curvature,
};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The adhered vesicle against the continuum adhered vesicle of the same
/// area, reduced volume, κ and W (`summary.json` → `adhesion`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdhesionReport {
    /// W R0²/κ, R0 = √(A/4π).
    pub reduced_adhesion: f64,
    /// Seifert & Lipowsky's contact condition √(2W/κ) (1/l̄).
    pub contact_condition: f64,
    /// The contact curvature: √(2W′/κ) of the continuum vesicle that best
    /// fits the free membrane near the contact line (1/l̄; `None` when no
    /// member fits: see `fit`).
    pub contact_curvature: Option<f64>,
    /// Its one-sigma error from the fit (1/l̄).
    pub contact_curvature_error: Option<f64>,
    /// The vesicle's top above its bound membrane (l̄).
    pub height: f64,
    /// The continuum vesicle's height at W (l̄).
    pub continuum_height: f64,
    /// π r² of the fitted contact line (l̄²; `None` when no member fits).
    pub contact_area: Option<f64>,
    /// The continuum vesicle's contact area π r_c² at W (l̄²).
    pub continuum_contact_area: f64,
    /// What the fit used, or why the contact curvature was not measured.
    pub fit: String,
}

/// Measures the closed vesicle `positions` (area `area`, reduced volume
/// `v`) on the plane substrate `adhesion`, with bending rigidity `kappa`,
/// against the continuum adhered vesicle. `Err` when the substrate is not
/// a plane or the continuum vesicle cannot be solved; a failed curvature
/// fit is reported inside.
pub fn measure(
    (adhesion, kappa): (&crate::energy::adhesion::AdhesionParams, f64),
    positions: &[[f64; 3]],
    area: f64,
    v: f64,
) -> Result<AdhesionReport, ContactFitError> {
    let crate::energy::wall::WallShape::Plane { point, normal } = adhesion.shape else {
        return Err(ContactFitError::NotAPlane);
    };
    let input = ContactFitInput {
        positions,
        point: point.into(),
        normal: normal.into(),
        range: adhesion.range,
        strength: adhesion.strength,
        kappa,
        area,
        reduced_volume: v,
    };
    let continuum = compare_with_continuum(&input)?;
    let r0 = (area / (4.0 * PI)).sqrt();
    let (curvature, error, contact_area, fit) = match fit_contact_curvature(&input) {
        Ok(fit) => (
            Some(fit.curvature),
            Some(fit.curvature_error),
            Some(PI * fit.contact_radius * fit.contact_radius),
            format!(
                "W'/W = {:.4} over {} vertices (rms {:.2e} l), contact line {:+.3} l from \
                 the fitted continuum vesicle's, bound membrane at {:+.3} l",
                fit.adhesion_ratio, fit.vertices, fit.rms, fit.contact_shift, fit.bound_height
            ),
        ),
        Err(e) => (
            None,
            None,
            None,
            format!("contact curvature not measured: {e}"),
        ),
    };
    Ok(AdhesionReport {
        reduced_adhesion: adhesion.strength * r0 * r0 / kappa,
        contact_condition: (2.0 * adhesion.strength / kappa).sqrt(),
        contact_curvature: curvature,
        contact_curvature_error: error,
        height: continuum.height,
        continuum_height: continuum.continuum_height,
        contact_area,
        continuum_contact_area: continuum.continuum_contact_area,
        fit,
    })
}

/// The `adhesion` section of `summary.json`
/// ([`crate::engine::summary_section`]): the [`AdhesionReport`] of the final
/// state of a closed vesicle on the plane substrate `substrate` with bending
/// rigidity `kappa` (left out for an open membrane, or when the continuum
/// vesicle cannot be solved there). The scene registers it when it has one
/// plane `Adhesion` term and a bending rigidity
/// ([`crate::scene::Scene::adhesion_substrate`]).
pub struct AdhesionSection {
    /// The substrate.
    pub substrate: crate::energy::adhesion::AdhesionParams,
    /// The bending rigidity κ (Ē).
    pub kappa: f64,
}

/// The section's name in `summary.json`.
pub const ADHESION_SECTION: &str = "adhesion";

impl crate::engine::summary_section::SummarySection for AdhesionSection {
    fn name(&self) -> &str {
        ADHESION_SECTION
    }

    fn measure(&self, sim: &crate::engine::simulation::Simulation) -> Option<serde_json::Value> {
        use crate::mesh::geometry::{enclosed_volume, reduced_volume, total_area};
        let membrane = sim.membrane();
        let topology = membrane.cached_topology();
        if topology.is_open() {
            return None;
        }
        let positions = sim.resource::<crate::engine::simulation::DensePositions>();
        let p = &positions.0;
        let area = total_area(p, &topology.faces);
        let v = reduced_volume(enclosed_volume(p, &topology.faces, p[0]), area);
        let points: Vec<[f64; 3]> = p.iter().map(|x| x.to_array()).collect();
        let report = measure((&self.substrate, self.kappa), &points, area, v).ok()?;
        serde_json::to_value(report).ok()
    }
}
