//! Energy minimisation: the kernels behind the minimiser system, its
//! convergence criteria and the status it reports.
//!
//! - [`fire`]: FIRE, inertial steps along the force (or along a
//!   preconditioned direction);
//! - [`axial`]: steps kept orthogonal to the deformations that break an
//!   axial symmetry;
//! - [`sobolev`]: the Sobolev metric that preconditions it, a sparse
//!   Cholesky factor of the cotangent Laplacian applied once to tangential
//!   and twice to normal components, with the exact constraints kept in the
//!   same metric.

pub mod axial;
pub mod cholesky;
pub mod fire;
pub mod sobolev;

pub use fire::{Fire, FireStep};

/// Why a minimisation ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The largest force fell below `force_tolerance` with every
    /// constraint held.
    ForceResidual,
    /// The energy changed by less than `energy_tolerance` over
    /// `energy_window` iterations with every constraint held.
    EnergyChange,
}

impl StopReason {
    /// The name used in summaries and messages.
    pub fn name(self) -> &'static str {
        match self {
            StopReason::ForceResidual => "force_residual",
            StopReason::EnergyChange => "energy_change",
        }
    }
}

/// The minimiser's progress, for series, summary and the CLI (a resource
/// that the `fire_minimiser` system writes every iteration).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MinimiserStatus {
    /// Why the minimisation ended; `None` while it runs, and at the end
    /// when the iteration cap came first.
    pub stopped_by: Option<StopReason>,
    /// The largest force on any vertex at the last iteration, constraint
    /// reactions removed (Ē/l̄).
    pub force_residual: f64,
    /// The total energy at the last iteration (Ē).
    pub energy: f64,
    /// |ΔE| / |E| over the last `energy_window` iterations (`None` until
    /// the window has filled since the last restart).
    pub energy_change: Option<f64>,
    /// The largest relative constraint violation at the last iteration.
    pub constraint_violation: f64,
    /// Restarts after a topology change (remesh event or flip).
    pub restarts: u64,
    /// Steps undone because they turned a face over or left a term's
    /// domain ([`crate::engine::force::ForceTerm::admits`]; each cut the
    /// step in half and restarted FIRE).
    pub folds_undone: u64,
    /// Factorisations of the preconditioner by its schedule (0 without
    /// one; a resumed run's factorisation of the checkpointed matrix is
    /// not counted).
    #[serde(default)]
    pub factorisations: u64,
    /// With `axisymmetric`: the largest force on a vertex along the two
    /// held quadrupolar modes at the last iteration (Ē/l̄), which
    /// `force_residual` leaves out as it leaves out the constraints'
    /// reactions. Near zero at an axisymmetric equilibrium of the
    /// unconstrained problem; what it holds is the mesh's own asymmetry.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axial_reaction: Option<f64>,
}
