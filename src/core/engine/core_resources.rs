//! The resources every simulation has (inserted by SimBuilder::new and the
//! core plugin): initial quantities, the clock, the dense mirrors of the
//! world, the seed, the invariant-check switch and whether scheduled
//! control-point changes are still to come.

use glam::DVec3;

/// Quantities of the initial mesh that targets are resolved against.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct InitialState {
    /// Vertex count N_initial.
    pub vertices: usize,
    /// Total lipid Σρ at the start (N_initial for a fresh mesh with ρ = 1;
    /// the saved total when starting from a state).
    pub lipid_total: f64,
    /// Total area (l̄²).
    pub area: f64,
    /// Enclosed volume (l̄³).
    pub volume: f64,
}

/// Simulated time and iteration count.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Clock {
    /// Completed iterations (accepted ticks).
    pub iteration: u64,
    /// Simulated time (s).
    pub time: f64,
}

/// Dense position mirror, by vertex slot (l̄). Gathered from the world's
/// [`crate::mesh::components::Position`] every tick; written back by integration.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DensePositions(pub Vec<DVec3>);

/// Dense lipid density mirror, by vertex slot (dimensionless; empty when the
/// scene declares no lipid density).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DenseLipid(pub Vec<f64>);

/// Seed of every random stream of the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Seed(pub u64);

/// Run the full mesh invariant check after every topology edit (always on
/// in debug builds; `remembrane run --check-invariants` in release).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CheckInvariants(pub bool);

impl Default for CheckInvariants {
    fn default() -> Self {
        Self(cfg!(debug_assertions))
    }
}

/// Why a system asked the run to end after the current tick (`None`: it
/// goes on to its iterations or duration). The minimiser sets it when a
/// convergence criterion holds; the run driver reads it after every tick.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StopRequest(pub Option<String>);

/// Whether a scheduled change of the control points is still to come after
/// the current iteration (written each tick by the `control_point_schedule` system;
/// absent without a schedule).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScheduledChangesAhead(pub bool);
