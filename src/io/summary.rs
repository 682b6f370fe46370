//! What `summary.json` holds: a run's status, energies, shape, remeshing
//! and minimiser.

use crate::engine::schedule::SystemTiming;
use crate::io::report::EnergyReport;

/// How a run ended.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    /// All iterations done.
    Completed,
    /// Stopped by a non-finite value; the last frame is the last good state.
    BlewUp,
}

/// `summary.json` (read back by [`RunSummary::read`]).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct RunSummary {
    /// Scene file.
    pub scene_file: String,
    /// Seed used.
    pub seed: u64,
    /// How the run ended.
    pub status: RunStatus,
    /// The error that stopped the run, if any.
    pub error: Option<String>,
    /// The last frame written, i.e. the last good state (relative path).
    pub last_good_frame: Option<String>,
    /// Iterations done.
    pub iterations: u64,
    /// Simulated time (s).
    pub simulated_time: f64,
    /// Wall time of the whole run (s).
    pub wall_time_s: f64,
    /// The final state: scene name, mesh size, energies by term, area,
    /// volume, reduced volume and mesh quality (flattened into the JSON).
    #[serde(flatten)]
    pub last: EnergyReport,
    /// Final shape in its principal frame (diameter, centre vs maximal
    /// height, axisymmetry, discocyte/stomatocyte/convex).
    pub shape: crate::analysis::shape::ShapeMetrics,
    /// Edges outside [l_−, l_+] at the end.
    pub abnormal_edges: usize,
    /// Remeshing outcome counts (split/merge × success/cancel/impossible/failure).
    pub remesh: RemeshSummary,
    /// Known biases of the scene's settings ([`crate::scene::Scene::cautions`]; omitted
    /// when none).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub cautions: Vec<String>,
    /// Where the run's time went, when one system dominated it (remeshing
    /// above half of the time); measured by the clock like `timings`, so it
    /// may differ between equal runs. Omitted when none.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub time_notes: Vec<String>,
    /// How the minimisation ended (scenes with `method: Minimise` only).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub minimiser: Option<MinimiserSummary>,
    /// The sections the scene's terms and plugins add
    /// ([`crate::engine::summary_section`]), by name, each at the top level
    /// of the file. The bundled ones: `edge_flips` (the Metropolis flips'
    /// proposals and outcomes, [`crate::engine::shared_resources::FlipStats`]),
    /// `maintenance_flips` (the fluid model's Delaunay flips,
    /// [`crate::engine::shared_resources::MaintenanceFlipStats`]), and, for
    /// completed runs, `adhesion`, the adhered vesicle against the continuum
    /// adhered vesicle ([`crate::analysis::adhesion::AdhesionReport`],
    /// closed membranes on one plane `Adhesion` substrate). Read one with
    /// [`RunSummary::section`].
    #[serde(flatten)]
    pub sections: std::collections::BTreeMap<String, serde_json::Value>,
    /// The exact constraints at the final state: targets, area, volume and
    /// the multipliers σ (`tension`, Ē/l̄²) and Δp (`pressure`, Ē/l̄³)
    /// (scenes with `constraints` only).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub constraints: Option<crate::constraint::ConstraintState>,
    /// The membrane model and what V_in's in-plane elasticity weighs at
    /// the final state ([`crate::fluid::ModelSummary`]).
    pub model: crate::fluid::ModelSummary,
    /// Frames written.
    pub frames: Vec<crate::io::output::FrameRecord>,
    /// Wall time per system.
    pub timings: Vec<SystemTiming>,
}

/// The keys of `summary.json`'s own fields: a plugin's section may not
/// take one of them (checked before a run starts; a test checks the list
/// against a written summary).
pub const SUMMARY_FIELDS: &[&str] = &[
    "scene_file",
    "seed",
    "status",
    "error",
    "last_good_frame",
    "iterations",
    "simulated_time",
    "wall_time_s",
    "scene",
    "vertices",
    "edges",
    "faces",
    "energies",
    "total_energy",
    "area",
    "volume",
    "reduced_volume",
    "quality",
    "shape",
    "abnormal_edges",
    "remesh",
    "cautions",
    "time_notes",
    "minimiser",
    "constraints",
    "model",
    "frames",
    "timings",
];

impl RunSummary {
    /// The section `name` read as a `T`: `Ok(None)` when the run has no
    /// such section, an error when it does not read as a `T`.
    pub fn section<T: serde::de::DeserializeOwned>(
        &self,
        name: &str,
    ) -> Result<Option<T>, serde_json::Error> {
        self.sections
            .get(name)
            .map(|v| serde_json::from_value(v.clone()))
            .transpose()
    }
}

/// How a minimisation ended, in `summary.json`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct MinimiserSummary {
    /// `force_residual` or `energy_change` (the criterion that held), or
    /// `iteration_cap` (neither held within `iterations`).
    pub stopped_by: String,
    /// Whether a convergence criterion held.
    pub converged: bool,
    /// The largest force on a vertex at the final state, constraint
    /// reactions removed (Ē/l̄).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub force_residual: f64,
    /// |ΔE| / |E| over the energy window at the end (absent until the
    /// window had filled since the last restart).
    pub energy_change: Option<f64>,
    /// The largest relative constraint violation at the end.
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub constraint_violation: f64,
    /// Restarts after topology changes.
    pub restarts: u64,
    /// Steps undone because they folded a face or left a term's domain.
    pub folds_undone: u64,
    /// Factorisations of the preconditioner (0 without one).
    #[serde(default)]
    pub factorisations: u64,
    /// With `axisymmetric`: the largest force along the held quadrupolar
    /// modes, left out of `force_residual` (Ē/l̄).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axial_reaction: Option<f64>,
}

/// Remeshing counts in `summary.json`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct RemeshSummary {
    /// Split outcomes.
    pub split: crate::remesh::OutcomeCounts,
    /// Merge outcomes.
    pub merge: crate::remesh::OutcomeCounts,
    /// Ticks that hit the per-tick event cap.
    pub overflow_ticks: u64,
    /// Ticks that ended with abnormal edges although each was attempted.
    pub unresolved_ticks: u64,
    /// Successful events.
    pub events: u64,
    /// Relaxation iterations by phase.
    pub relax_iterations: crate::remesh::RelaxIterations,
    /// σ(|r|) of the event positions (l̄).
    pub event_position_spread: f64,
}
