//! [`Simulation`]: the world and typed resources of a built scene plus the
//! schedule of systems that advances them; [`SimBuilder`] and [`Plugin`],
//! through which built-in and user physics register alike. The core
//! resources and the errors are re-exported here.

pub use crate::engine::core_resources::{
    CheckInvariants, Clock, DenseLipid, DensePositions, InitialState, Seed, StopRequest,
};
pub use crate::engine::error::{BuildError, SimError};
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

    /// Adds a recorder: its columns and point data go into every frame.
    pub fn add_recorder(&mut self, recorder: impl crate::engine::recorder::Recorder) -> &mut Self {
        push_recorder(&mut self.resources, Box::new(recorder));
        self
    }

    /// The simulation (its schedule is validated by [`Simulation::start`]
    /// or the first tick).
    pub fn build(self) -> Simulation {
        Simulation {
            resources: self.resources,
            builder: Some(self.schedule),
            schedule: None,
        }
    }
}

fn push_recorder(resources: &mut Resources, recorder: Box<dyn crate::engine::recorder::Recorder>) {
    if !resources.contains::<crate::engine::recorder::Recorders>() {
        resources.insert(crate::engine::recorder::Recorders::default());
    }
    if let Some(r) = resources.value_mut::<crate::engine::recorder::Recorders>() {
        r.0.push(recorder);
    }
}

/// A simulation: the world and resources, plus the schedule of systems
/// that advances them.
pub struct Simulation {
    resources: Resources,
    builder: Option<ScheduleBuilder>,
    schedule: Option<Schedule>,
}

impl Simulation {
    /// The schedule builder while the run has not started; `name` is what
    /// the caller is adding (for the error).
    fn pending(&mut self, name: &str) -> Result<&mut ScheduleBuilder, SimError> {
        self.builder
            .as_mut()
            .ok_or_else(|| SimError::AlreadyStarted(name.to_string()))
    }

    /// Adds a typed system to `stage` before the run starts; returns the
    /// builder handle for `before`/`after` constraints. Errors if the run
    /// started.
    pub fn add_system(
        &mut self,
        stage: Stage,
        system: impl System,
    ) -> Result<Registered<'_>, SimError> {
        Ok(self.pending(system.name())?.add(stage, system))
    }

    /// Adds a dynamic system (access checked at every borrow) to `stage`
    /// before the run starts.
    pub fn add_dynamic_system(
        &mut self,
        stage: Stage,
        system: impl crate::engine::schedule::DynamicSystem,
    ) -> Result<Registered<'_>, SimError> {
        Ok(self.pending(system.name())?.add_dynamic(stage, system))
    }

    /// Whether the schedule was taken to be built (by [`Simulation::start`]
    /// or the first tick): nothing can be registered any more.
    pub(crate) fn is_sealed(&self) -> bool {
        self.builder.is_none()
    }

    /// All resources, for the engine's own registrations before the start.
    pub(crate) fn resources_mut(&mut self) -> &mut Resources {
        &mut self.resources
    }

    /// Adds a recorder before the run's frame writer takes the recorders
    /// (see [`crate::engine::recorder`]).
    pub fn add_recorder(
        &mut self,
        recorder: impl crate::engine::recorder::Recorder,
    ) -> Result<(), SimError> {
        if self.schedule.is_some() {
            return Err(SimError::AlreadyStarted(recorder.name().to_string()));
        }
        push_recorder(&mut self.resources, Box::new(recorder));
        Ok(())
    }

    /// Removes and returns resource `T`.
    pub fn remove_resource<T: Resource>(&mut self) -> Option<T> {
        self.resources.remove::<T>()
    }

    /// Runs the Gather, Forces and Observe systems once: the current state
    /// with its forces is recorded (the final frame of a run).
    pub fn observe(&mut self) -> Result<(), SimError> {
        self.run_stages(&[Stage::Gather, Stage::Forces, Stage::Observe])
    }

    /// Runs the systems of `stages` once, in order (starting the schedule
    /// if needed), without the others: e.g. Gather and Forces evaluate the
    /// current state's forces without moving anything.
    pub fn run_stages(&mut self, stages: &[Stage]) -> Result<(), SimError> {
        self.start()?;
        let schedule = self.schedule.as_mut().expect("started");
        schedule.run_stages(stages, &self.resources)
    }

    /// Inserts (or replaces) a resource before the run starts.
    pub fn insert_resource<T: Resource>(&mut self, value: T) -> Result<(), SimError> {
        if self.schedule.is_some() {
            return Err(SimError::AlreadyStarted(
                crate::engine::resources::ResourceId::of::<T>()
                    .name()
                    .to_string(),
            ));
        }
        self.resources.insert(value);
        Ok(())
    }

    /// Validates and fixes the schedule (done by the first tick otherwise).
    pub fn start(&mut self) -> Result<(), SimError> {
        if let Some(builder) = self.builder.take() {
            self.schedule = Some(builder.build(&self.resources)?);
        }
        Ok(())
    }

    /// Runs one tick of every system.
    pub fn tick(&mut self) -> Result<(), SimError> {
        self.start()?;
        let schedule = self.schedule.as_mut().expect("started");
        schedule.run_tick(&self.resources)
    }

    /// The schedule (after [`Simulation::start`]).
    pub fn schedule(&self) -> Option<&Schedule> {
        self.schedule.as_ref()
    }

    /// The schedule, once started (to restore its systems' states).
    pub fn schedule_mut(&mut self) -> Option<&mut Schedule> {
        self.schedule.as_mut()
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
