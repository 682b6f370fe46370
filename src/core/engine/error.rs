//! The engine's errors: a run that cannot continue ([`SimError`]), a plugin
//! that cannot be added ([`BuildError`]), a schedule that cannot run
//! ([`ScheduleError`]), a checkpointed state that does not fit
//! ([`StateError`]).

use crate::engine::resources::ResourceId;
use crate::mesh::topology::TopologyError;

/// Why `restore_state` could not give a system, force term or recorder
/// its checkpointed state back.
#[derive(Debug, thiserror::Error)]
pub enum StateError {
    /// It keeps no state, yet the checkpoint holds one for it.
    #[error("it keeps no state")]
    Stateless,
    /// The saved value does not deserialize into its state.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// A field is missing or does not fit (the reason names the field).
    #[error("{0}")]
    Invalid(String),
}

impl From<&str> for StateError {
    fn from(reason: &str) -> Self {
        StateError::Invalid(reason.to_string())
    }
}

impl From<String> for StateError {
    fn from(reason: String) -> Self {
        StateError::Invalid(reason)
    }
}

/// A run cannot continue.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The schedule is invalid (reported before tick 0).
    #[error("invalid schedule: {0}")]
    Schedule(#[from] ScheduleError),
    /// The world's mesh entities are inconsistent.
    #[error("broken topology: {0}")]
    Topology(#[from] TopologyError),
    /// A non-finite value appeared.
    #[error(
        "blow-up at iteration {iteration}: {quantity} of {element} is not finite ({value}) in `{term}`"
    )]
    BlowUp {
        /// Iteration being computed (completed iterations + 1).
        iteration: u64,
        /// What went non-finite: "force", "time step" or "position".
        quantity: &'static str,
        /// The energy term or system responsible.
        term: String,
        /// The vertex or edge, e.g. "vertex 12".
        element: String,
        /// The offending value.
        value: String,
    },
    /// A face turned over within one step: the explicit step was too large
    /// for the forces and the mesh would fold (finite but garbage).
    #[error(
        "mesh folded at iteration {iteration}: face {face} (vertices {vertices:?}, shortest edge {shortest_edge:.3} l̄) turned over within one step of Δt = {dt:e} s (largest drift μ|F|Δt of its corners {drift:.3e} l̄, thermal noise {noise:.3e} l̄ per component); {cause}"
    )]
    MeshFolded {
        /// Iteration being computed (completed iterations + 1).
        iteration: u64,
        /// Face slot.
        face: usize,
        /// Its vertex slots.
        vertices: [u32; 3],
        /// The step (s).
        dt: f64,
        /// Its shortest edge before the step (l̄).
        shortest_edge: f64,
        /// The largest deterministic move μ|F|Δt of its corners (l̄).
        drift: f64,
        /// The noise amplitude sqrt(2 μ k_BT Δt) per component (l̄).
        noise: f64,
        /// Which of the two moved it, with the fix.
        cause: FoldCause,
    },
    /// A step turned the membrane inside out (enclosed volume ≤ 0).
    #[error(
        "membrane turned inside out at iteration {iteration}: enclosed volume {volume:e} after a step of Δt = {dt:e} s; the step is too large for the forces (lower dynamics.dt_max or dynamics.max_displacement)"
    )]
    InsideOut {
        /// Iteration being computed (completed iterations + 1).
        iteration: u64,
        /// Enclosed volume after the step (l̄³).
        volume: f64,
        /// The step (s).
        dt: f64,
    },
    /// The minimiser could not take a step without turning a face over,
    /// even after shrinking its step to the smallest it allows.
    #[error(
        "minimiser stuck at iteration {iteration}: every step down to Δt = {dt:e} turned face {face} (vertices {vertices:?}) over; the mesh is too distorted for its forces (lower dynamics.method.Minimise.max_step, or start from a smoother mesh)"
    )]
    MinimiserStuck {
        /// Iteration being computed (completed iterations + 1).
        iteration: u64,
        /// The last step tried (fictitious time).
        dt: f64,
        /// Face slot that turned over.
        face: usize,
        /// Its vertex slots.
        vertices: [u32; 3],
    },
    /// The minimiser could not take a step that stays in every term's
    /// domain, even after shrinking its step to the smallest it allows.
    #[error(
        "minimiser stuck at iteration {iteration}: every step down to Δt = {dt:e} left the domain of the term `{term}` (for species: a fraction reached 0 or 1 at fixed amounts; lower dynamics.method.Minimise.max_step, or the protein amounts)"
    )]
    StepRefused {
        /// Iteration being computed (completed iterations + 1).
        iteration: u64,
        /// The last step tried (fictitious time).
        dt: f64,
        /// The term that refused it.
        term: String,
    },
    /// The minimiser's preconditioner could not be built.
    #[error("minimiser at iteration {iteration}: {source}")]
    Preconditioner {
        /// Iteration being computed (completed iterations + 1).
        iteration: u64,
        /// What failed.
        source: crate::minimise::sobolev::MetricError,
    },
    /// The protein species' fields could not be relaxed at the shape.
    #[error("species at iteration {iteration}: {source}")]
    Species {
        /// Iteration being computed (completed iterations + 1).
        iteration: u64,
        /// What failed.
        source: crate::species::relax::RelaxError,
    },
    /// The protein species' fields could not be moved over a tick.
    #[error("species at iteration {iteration}: {source}")]
    SpeciesTransport {
        /// The iteration whose tick it was.
        iteration: u64,
        /// What failed.
        source: crate::species::transport::TransportError,
    },
    /// An output could not be written.
    #[error("{0}")]
    Output(String),
    /// A system could not be handed its resources (an undeclared access
    /// of a dynamic system, or a resource removed after validation).
    #[error("system `{system}`: {source}")]
    Resource {
        /// The system.
        system: String,
        /// What went wrong.
        source: crate::engine::resources::FetchError,
    },
    /// A plugin could not be registered.
    #[error(transparent)]
    Build(#[from] BuildError),
    /// A checkpoint could not be written, or its state does not fit the
    /// simulation it is restored into.
    #[error("checkpoint: {0}")]
    Checkpoint(String),
}

/// What turned a face over within one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FoldCause {
    /// The forces' deterministic move was too large.
    Drift,
    /// The thermal noise (its step exceeded twice the drift).
    Noise,
    /// Both, within a factor of two of each other.
    Both,
}

impl FoldCause {
    /// The cause of a fold whose corners drifted by at most `drift` with a
    /// noise of `noise` per component (l̄): the noise's 3-D step √3·noise
    /// against the drift.
    pub fn of(drift: f64, noise: f64) -> Self {
        let ratio = 3f64.sqrt() * noise / drift;
        if ratio > 2.0 {
            FoldCause::Noise
        } else if ratio < 0.5 {
            FoldCause::Drift
        } else {
            FoldCause::Both
        }
    }
}

impl std::fmt::Display for FoldCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FoldCause::Drift => {
                "the step is too large for the forces (lower dynamics.dt_max or dynamics.max_displacement, keep dynamics.bending_step_limit on, or add a Vin term, whose segments limit the step)"
            }
            FoldCause::Noise => {
                "the thermal noise turned a face over (the step rule bounds the drift, not the noise): lower dynamics.dt_max (the noise step scales as √Δt), stiffen Vin (a larger v0 keeps edges from collapsing) or lower dynamics.temperature"
            }
            FoldCause::Both => {
                "the drift and the thermal noise together turned a face over: lower dynamics.dt_max, stiffen Vin (a larger v0 keeps edges from collapsing) or lower dynamics.temperature"
            }
        })
    }
}

/// A plugin could not be added to a simulation.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// Two force terms share a name.
    #[error(transparent)]
    DuplicateTerm(#[from] DuplicateTerm),
    /// A plugin needs a resource that an earlier plugin inserts.
    #[error("{what} needs resource `{resource}`: add {plugin} first")]
    Requires {
        /// What was being added.
        what: String,
        /// The missing resource.
        resource: &'static str,
        /// The plugin that provides it.
        plugin: &'static str,
    },
    /// A plugin's configuration is invalid.
    #[error("field `{field}`: {reason}")]
    Invalid {
        /// The field (relative to the plugin's declaration).
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// The systems do not form a valid schedule.
    #[error(transparent)]
    Schedule(#[from] ScheduleError),
}

/// A schedule that cannot run.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ScheduleError {
    /// A stage name that does not exist.
    #[error(
        "unknown stage `{0}` (stages: Prepare, Forces, TimeStep, Integrate, BarrierCheck, Remesh, Diffuse, Observe)"
    )]
    UnknownStage(String),
    /// Two systems share a name.
    #[error("two systems are named `{0}`")]
    DuplicateName(String),
    /// A before/after constraint names a system not in the same stage.
    #[error(
        "system `{system}` is ordered relative to `{other}`, which is not a system of stage {stage}"
    )]
    UnknownOrderTarget {
        /// The constrained system.
        system: String,
        /// The missing system.
        other: String,
        /// The stage.
        stage: &'static str,
    },
    /// The before/after constraints of a stage form a cycle.
    #[error("ordering cycle in stage {stage} among: {systems}")]
    Cycle {
        /// The stage.
        stage: &'static str,
        /// Systems on the cycle (comma separated).
        systems: String,
    },
    /// A system writes a resource its stage does not allow
    /// (`ScheduleBuilder::restrict_writes`).
    #[error(
        "system `{system}` in the {stage} stage writes `{resource}`; that stage's systems may write only {allowed}"
    )]
    StageWrites {
        /// The system.
        system: String,
        /// Its stage.
        stage: &'static str,
        /// The forbidden write (the resource's type name).
        resource: &'static str,
        /// What the stage's systems may write.
        allowed: String,
    },
    /// A system needs a resource that no plugin inserted.
    #[error(
        "system `{system}` needs resource `{resource}`, which no plugin inserted (resources: {available})"
    )]
    MissingResource {
        /// The system.
        system: String,
        /// The missing resource.
        resource: ResourceId,
        /// The resources that exist (comma separated).
        available: String,
    },
    /// A system declares one resource twice, at least once as a write.
    #[error("system `{system}` borrows `{resource}` twice, once for writing")]
    ConflictingAccess {
        /// The system.
        system: String,
        /// The resource.
        resource: ResourceId,
    },
}

/// A force term's name is already taken.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("a force term named `{0}` is already registered")]
pub struct DuplicateTerm(pub String);
