//! [`Simulation`]: a built scene: the simulation state (world, dense
//! mirrors, forces, clock) and the schedule of systems that advances it.

use crate::energy::vin::Segmentation;
use crate::force::{ForceEvaluation, ForceSet};
use crate::membrane::Membrane;
use crate::params::{DynamicsParams, RemeshParams};
use crate::schedule::{Schedule, ScheduleBuilder, ScheduleError, Stage, System};
use crate::timestep::TimeStepChoice;
use crate::topology::TopologyError;
use glam::DVec3;
use std::sync::Arc;

/// Quantities of the initial mesh that targets are resolved against.
#[derive(Clone, Copy, Debug, PartialEq)]
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
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Clock {
    /// Completed iterations (accepted ticks).
    pub iteration: u64,
    /// Simulated time (s).
    pub time: f64,
}

/// Everything systems read and write.
pub struct SimState {
    /// The world (source of truth) and its caches.
    pub membrane: Membrane,
    /// The force terms.
    pub forces: ForceSet,
    /// The current tick's forces.
    pub evaluation: ForceEvaluation,
    /// Dense position mirror, by vertex slot (l̄).
    pub positions: Vec<DVec3>,
    /// Dense lipid density mirror (empty without lipid density).
    pub lipid: Vec<f64>,
    /// Simulated time and iterations.
    pub clock: Clock,
    /// The current tick's time step.
    pub time_step: TimeStepChoice,
    /// Dynamics parameters.
    pub dynamics: DynamicsParams,
    /// Barrier-crossing triggers.
    pub remesh: RemeshParams,
    /// V_in segmentation (when the scene uses V_in).
    pub segmentation: Option<Arc<Segmentation>>,
    /// Initial-mesh quantities.
    pub initial: InitialState,
    /// Seed of all random streams.
    pub seed: u64,
    /// Edges (slots) outside [l_−, l_+] after the last integration.
    pub abnormal_edges: Vec<u32>,
    /// Allowed valences (remeshing keeps every vertex inside).
    pub valence: crate::mesh::ValenceRange,
    /// Remeshing outcome counts and event positions.
    pub remesh_stats: crate::remesh::RemeshStats,
    /// Whether this tick's remeshing was triggered (abnormal edges existed).
    pub remesh_triggered: bool,
    /// Run the full mesh invariant check after every topology edit (always
    /// on in debug builds; `remembrane run --check-invariants` in release).
    pub check_invariants: bool,
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
        "mesh folded at iteration {iteration}: face {face} (vertices {vertices:?}) turned over within one step of Δt = {dt:e} s; the step is too large for the forces (lower dynamics.dt_max or dynamics.max_displacement, or add a Vin term, whose segments limit the step)"
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
    /// An output could not be written.
    #[error("{0}")]
    Output(String),
    /// A system was added after the schedule was fixed by the first tick.
    #[error("system `{0}` can only be added before the first tick")]
    AlreadyStarted(String),
}

/// A simulation: state plus schedule.
pub struct Simulation {
    /// The state systems operate on.
    pub state: SimState,
    builder: Option<ScheduleBuilder>,
    schedule: Option<Schedule>,
}

impl Simulation {
    /// A simulation of `membrane` under `forces`, with the built-in systems
    /// registered (forces, time step, integration, barrier check).
    pub fn new(membrane: Membrane, forces: ForceSet, initial: InitialState) -> Self {
        let terms = forces.names();
        let state = SimState {
            membrane,
            forces,
            evaluation: ForceEvaluation::default(),
            positions: Vec::new(),
            lipid: Vec::new(),
            clock: Clock::default(),
            time_step: TimeStepChoice::default(),
            dynamics: DynamicsParams::default(),
            remesh: RemeshParams::default(),
            segmentation: None,
            initial,
            seed: 1,
            abnormal_edges: Vec::new(),
            valence: crate::mesh::ValenceRange::default(),
            remesh_stats: crate::remesh::RemeshStats::default(),
            remesh_triggered: false,
            check_invariants: cfg!(debug_assertions),
        };
        let mut builder = ScheduleBuilder::new();
        crate::systems::register_builtin(&mut builder, &terms);
        Self {
            state,
            builder: Some(builder),
            schedule: None,
        }
    }

    /// Adds a system to `stage` before the run starts; returns the builder
    /// handle for `before`/`after` constraints. Errors if the run started.
    pub fn add_system(
        &mut self,
        stage: Stage,
        system: Box<dyn System>,
    ) -> Result<crate::schedule::Registered<'_>, SimError> {
        let name = system.name().to_string();
        let builder = self
            .builder
            .as_mut()
            .ok_or(SimError::AlreadyStarted(name))?;
        Ok(builder.add(stage, system))
    }

    /// Validates and fixes the schedule (done by the first tick otherwise).
    pub fn start(&mut self) -> Result<(), SimError> {
        if let Some(builder) = self.builder.take() {
            self.schedule = Some(builder.build()?);
        }
        Ok(())
    }

    /// Runs one tick of every system.
    pub fn tick(&mut self) -> Result<(), SimError> {
        self.start()?;
        let schedule = self.schedule.as_mut().expect("started");
        schedule.run_tick(&mut self.state)
    }

    /// The schedule (after [`Simulation::start`]).
    pub fn schedule(&self) -> Option<&Schedule> {
        self.schedule.as_ref()
    }

    /// Refreshes the caches, gathers the dense mirror and evaluates all force
    /// terms (outside the schedule; used for reports).
    pub fn evaluate_forces(&mut self) -> Result<&ForceEvaluation, TopologyError> {
        let s = &mut self.state;
        s.membrane.topology()?;
        s.membrane.gather_positions(&mut s.positions);
        s.membrane.gather_lipid(&mut s.lipid);
        s.forces.evaluate(
            &s.membrane.world,
            s.membrane.cached_topology(),
            &s.positions,
            &s.lipid,
            &mut s.evaluation,
        );
        s.membrane.scatter_forces(&s.evaluation.total);
        Ok(&s.evaluation)
    }
}
