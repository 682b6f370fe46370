//! The species' resources in a simulation: [`SpeciesModel`], what the
//! scene declared (the species, the membrane's bending they modify, how
//! their fields relax), and [`SpeciesStatus`], what the relaxation last
//! reached (the chemical potentials, the counts and their drift), which
//! the recorder and the summary report.

use crate::species::free_energy::BaseBending;
use crate::species::params::SpeciesSet;
use crate::species::relax::RelaxSettings;
use serde::{Deserialize, Serialize};

/// The declared species and how they are treated.
#[derive(Clone, Debug, PartialEq)]
pub struct SpeciesModel {
    /// The species, their interactions and k_BT.
    pub set: SpeciesSet,
    /// The membrane's bending, which the curvature couplings modify.
    pub base: BaseBending,
    /// How far the fields are relaxed at each shape (with the minimiser).
    pub relax: RelaxSettings,
}

/// What the species' fields reached, by species in declaration order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SpeciesStatus {
    /// The species' names.
    pub names: Vec<String>,
    /// Each chemical potential μ_s (Ē per protein): a conserved species'
    /// multiplier (in the series `NaN` until the fields have been relaxed),
    /// in dynamics its mean over the area; a bulk species' given value.
    pub chemical_potentials: Vec<f64>,
    /// Each conserved species' count at the start (proteins; the bulk
    /// species' start count).
    pub initial_counts: Vec<f64>,
    /// Each count now (proteins).
    pub counts: Vec<f64>,
    /// The field relaxations run.
    pub relaxations: u64,
    /// Newton steps over all relaxations.
    pub newton_steps: u64,
    /// The last relaxation's residual (Ē/l̄²).
    pub residual: f64,
    /// The steps of the fields' transport in overdamped dynamics over the
    /// run (they also count the draws of its noise).
    #[serde(default)]
    pub transport_steps: u64,
    /// Vertices whose fields a relaxation first brought back inside (0, 1),
    /// over the run (a remesh event had squeezed their cells under their
    /// proteins; each amount kept).
    #[serde(default)]
    pub repaired_vertices: u64,
}
