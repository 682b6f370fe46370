//! [`Simulation`]: the world and typed resources of a built scene plus the
//! schedule of systems that advances them; [`SimBuilder`] and [`Plugin`],
//! through which built-in and user physics register alike. The core
//! resources and the errors are re-exported here.

pub use crate::engine::core_resources::{
    CheckInvariants, Clock, DenseLipid, DensePositions, InitialState, Seed, StopRequest,
};
pub use crate::engine::error::{BuildError, SimError};
pub use crate::engine::frame_clock::{CurrentFrame, FrameSchedule};
use crate::engine::persisted::PersistedResources;
use crate::engine::resources::{Res, Resource, Resources};
use crate::engine::schedule::{Registered, Schedule, ScheduleBuilder, Stage, System};
use crate::mesh::membrane::Membrane;
use glam::DVec3;

/// A plugin: anything that registers resources and systems on a
/// [`SimBuilder`]. Every `FnOnce(&mut SimBuilder) -> Result<(), BuildError>`
/// is one; configurable plugins are structs implementing [`Plugin::build`].
/// Built-in physics registers itself through this same interface.
pub trait Plugin {
    /// Registers the plugin's resources and systems.
    fn build(self, builder: &mut SimBuilder) -> Result<(), BuildError>;
}

impl<F: FnOnce(&mut SimBuilder) -> Result<(), BuildError>> Plugin for F {
    fn build(self, builder: &mut SimBuilder) -> Result<(), BuildError> {
        self(builder)
    }
}

/// Builds a [`Simulation`] in one phase: the membrane and its initial
/// quantities, then plugins, each adding its own resources and systems.
pub struct SimBuilder {
    resources: Resources,
    schedule: ScheduleBuilder,
}

impl SimBuilder {
    /// A builder holding `membrane` (the world) and `initial` as resources.
    pub fn new(membrane: Membrane, initial: InitialState) -> Self {
        let mut resources = Resources::new();
        resources.insert(membrane);
        resources.insert(initial);
        Self {
            resources,
            schedule: ScheduleBuilder::new(),
        }
    }

    /// Adds `plugin`.
    pub fn add_plugin(&mut self, plugin: impl Plugin) -> Result<&mut Self, BuildError> {
        plugin.build(self)?;
        Ok(self)
    }

    /// Inserts (or replaces) a resource.
    pub fn insert_resource<T: Resource>(&mut self, value: T) -> &mut Self {
        self.resources.insert(value);
        self
    }

    /// Declares resource `T` part of the run's state that carries from one
    /// tick to the next, so checkpoints save it and a resumed run gets it
    /// back (see [`crate::engine::persisted`]). Resources that the scene sets up or
    /// that are recomputed every tick need no declaration.
    pub fn persist_resource<T>(&mut self) -> &mut Self
    where
        T: Resource + serde::Serialize + serde::de::DeserializeOwned,
    {
        if !self.resources.contains::<PersistedResources>() {
            self.resources.insert(PersistedResources::default());
        }
        if let Some(p) = self.resources.value_mut::<PersistedResources>() {
            p.add::<T>();
        }
        self
    }

    /// The initial mesh's area, volume and lipid total, for a plugin that
    /// resolves a target against them; `what` names the plugin in the
    /// error when [`SimBuilder::new`] did not insert them.
    pub fn initial_state(&self, what: &str) -> Result<InitialState, BuildError> {
        self.resources
            .get::<InitialState>()
            .map(|i| *i)
            .map_err(|_| BuildError::Requires {
                what: what.to_string(),
                resource: "InitialState",
                plugin: "SimBuilder::new",
            })
    }

    /// The resources so far.
    pub fn resources(&self) -> &Resources {
        &self.resources
    }

    /// A resource inserted so far, for a plugin to adjust.
    pub fn resource_mut<T: Resource>(&mut self) -> Option<&mut T> {
        self.resources.value_mut::<T>()
    }

    /// Adds a typed system to `stage`; returns the handle for
    /// `before`/`after` constraints.
    pub fn add_system(&mut self, stage: Stage, system: impl System) -> Registered<'_> {
        self.schedule.add(stage, system)
    }

    /// Lets the systems of `stage` write only `allowed`
    /// ([`ScheduleBuilder::restrict_writes`]); checked when the schedule is
    /// built.
    pub fn restrict_stage_writes(
        &mut self,
        stage: Stage,
        allowed: &[crate::engine::resources::ResourceId],
    ) -> &mut Self {
        self.schedule.restrict_writes(stage, allowed);
        self
    }

    /// Adds a dynamic system (access checked at every borrow) to `stage`.
    pub fn add_dynamic_system(
        &mut self,
        stage: Stage,
        system: impl crate::engine::schedule::DynamicSystem,
    ) -> Registered<'_> {
        self.schedule.add_dynamic(stage, system)
    }

    /// All resources so far, for the engine's own registrations (force
    /// terms: [`crate::engine::force`]).
    pub(crate) fn resources_mut(&mut self) -> &mut Resources {
        &mut self.resources
    }

    /// Adds a recorder ([`crate::engine::recorder`]): a typed Observe-stage
    /// system, run after the frame clock, whose columns and point data go
    /// into every frame.
    pub fn add_recorder<R: crate::engine::recorder::Recorder>(&mut self, recorder: R) -> &mut Self {
        self.add_frame_clock();
        self.schedule
            .add(
                Stage::Observe,
                crate::engine::recorder::RecorderSystem::new(recorder),
            )
            .after(crate::engine::frame_clock::FRAME_CLOCK);
        self
    }

    /// Adds the frame clock once ([`crate::engine::frame_clock`]): the
    /// `frame_clock` system, the [`FrameSchedule`] (no frame due until a run
    /// sets it; kept by checkpoints) and the [`CurrentFrame`] recorders
    /// fill. [`SimBuilder::add_recorder`] calls it.
    pub fn add_frame_clock(&mut self) -> &mut Self {
        if !self.resources.contains::<FrameSchedule>() {
            self.resources.insert(CurrentFrame::default());
            self.resources.insert(FrameSchedule::never());
            self.persist_resource::<FrameSchedule>();
            self.schedule
                .add(Stage::Observe, crate::engine::frame_clock::FrameClock);
        }
        self
    }

    /// The simulation, sealed: its schedule is validated against the
    /// resources and ordered here, and nothing can be registered after.
    pub fn build(self) -> Result<Simulation, BuildError> {
        let schedule = self.schedule.build(&self.resources)?;
        Ok(Simulation {
            resources: self.resources,
            schedule,
        })
    }
}

/// A simulation: the world and resources, plus the validated schedule of
/// systems that advances them. Built sealed ([`SimBuilder::build`]): what
/// runs is fixed; resources keep their values' freedom (a run sets its
/// frame schedule and output directory before the first tick).
///
/// Systems, force terms and recorders join on the [`SimBuilder`]; a sealed
/// simulation has no method to add one:
///
/// ```compile_fail,E0599
/// use remembrane_core::engine::schedule::Stage;
/// use remembrane_core::engine::simulation::Simulation;
///
/// fn too_late(sim: &mut Simulation) {
///     sim.add_system(Stage::Observe, ()); // only `SimBuilder::add_system` exists
/// }
/// ```
pub struct Simulation {
    resources: Resources,
    schedule: Schedule,
}

impl Simulation {
    /// Runs the Gather, Forces, Observe and Output systems once: the
    /// current state with its forces is recorded (the final frame of a run).
    pub fn observe(&mut self) -> Result<(), SimError> {
        self.run_stages(&[Stage::Gather, Stage::Forces, Stage::Observe, Stage::Output])
    }

    /// Runs the systems of `stages` once, in order (starting the schedule
    /// if needed), without the others: e.g. Gather and Forces evaluate the
    /// current state's forces without moving anything.
    pub fn run_stages(&mut self, stages: &[Stage]) -> Result<(), SimError> {
        self.schedule.run_stages(stages, &self.resources)
    }

    /// Runs one tick of every system.
    pub fn tick(&mut self) -> Result<(), SimError> {
        self.schedule.run_tick(&self.resources)
    }

    /// The schedule.
    pub fn schedule(&self) -> &Schedule {
        &self.schedule
    }

    /// The schedule, mutably (to restore its systems' states).
    pub fn schedule_mut(&mut self) -> &mut Schedule {
        &mut self.schedule
    }

    /// All resources.
    pub fn resources(&self) -> &Resources {
        &self.resources
    }

    /// Resource `T`. Panics if no plugin inserted it (use
    /// [`Simulation::resources`] to test).
    pub fn resource<T: Resource>(&self) -> Res<'_, T> {
        self.resources
            .get::<T>()
            .unwrap_or_else(|e| panic!("Simulation::resource: {e}"))
    }

    /// Resource `T`, mutably. Panics if no plugin inserted it.
    pub fn resource_mut<T: Resource>(&mut self) -> &mut T {
        let id = crate::engine::resources::ResourceId::of::<T>();
        self.resources
            .value_mut::<T>()
            .unwrap_or_else(|| panic!("Simulation::resource_mut: resource `{id}` does not exist"))
    }

    /// Simulated time and iterations.
    pub fn clock(&self) -> Clock {
        *self.resource::<Clock>()
    }

    /// The membrane (world and topology cache).
    pub fn membrane(&self) -> Res<'_, Membrane> {
        self.resource::<Membrane>()
    }

    /// The membrane, mutably.
    pub fn membrane_mut(&mut self) -> &mut Membrane {
        self.resource_mut::<Membrane>()
    }

    /// The dense positions as of the last gather or integration (l̄).
    pub fn positions(&self) -> Vec<DVec3> {
        self.resource::<DensePositions>().0.clone()
    }
}
