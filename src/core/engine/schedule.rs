//! Ordered systems: stages, registration with before/after constraints,
//! validation when the schedule is built, and per-system timing.
//!
//! A tick runs the stages in [`Stage::ALL`] order; within a stage, systems
//! run in registration order adjusted by their `before`/`after`
//! constraints. Built-in systems register through the same path as a
//! user's ([`crate::engine::simulation::SimBuilder::add_system`]).
//!
//! A [`System`] names its data in its type ([`System::Data`], a tuple of
//! [`Res`](crate::engine::resources::Res) / [`ResMut`](crate::engine::resources::ResMut)),
//! so its declared access is derived, never written by hand, and it can
//! touch nothing else. When the schedule is built every declared resource
//! must exist (or be optional), no system may borrow one resource twice
//! with a write, and a stage that a plugin restricted
//! ([`ScheduleBuilder::restrict_writes`]) may write only what it allowed:
//! the core plugin keeps the Forces stage to the force buffers.

pub use crate::engine::error::ScheduleError;
use crate::engine::error::SimError;
use crate::engine::resources::{Access, CheckedResources, ResourceId, Resources, SystemData};
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// The ordered stages of a tick.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
pub enum Stage {
    /// Apply scheduled changes (control points) before anything is gathered.
    Prepare,
    /// Refresh caches, gather the dense state and the per-face geometry.
    Gather,
    /// Accumulate forces (the core plugin lets systems here write only the
    /// force buffers).
    Forces,
    /// Record the state of the last completed iteration with the forces the
    /// next step applies (frames, series, observables); nothing moves yet.
    Observe,
    /// Write what Observe recorded (the run's frames); nothing moves yet.
    Output,
    /// Choose the time step.
    TimeStep,
    /// Move the vertices.
    Integrate,
    /// Detect edges that crossed a V_in barrier.
    BarrierCheck,
    /// Split and merge.
    Remesh,
    /// Lipid diffusion and the protein species' transport.
    Diffuse,
}

impl Stage {
    /// All stages in tick order.
    pub const ALL: [Stage; 10] = [
        Stage::Prepare,
        Stage::Gather,
        Stage::Forces,
        Stage::Observe,
        Stage::Output,
        Stage::TimeStep,
        Stage::Integrate,
        Stage::BarrierCheck,
        Stage::Remesh,
        Stage::Diffuse,
    ];

    /// The stage's name as written in scenes (`systems: [Custom(stage: ..)]`)
    /// and reports.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Prepare => "Prepare",
            Stage::Gather => "Gather",
            Stage::Forces => "Forces",
            Stage::Observe => "Observe",
            Stage::Output => "Output",
            Stage::TimeStep => "TimeStep",
            Stage::Integrate => "Integrate",
            Stage::BarrierCheck => "BarrierCheck",
            Stage::Remesh => "Remesh",
            Stage::Diffuse => "Diffuse",
        }
    }

    /// Parses a stage name.
    pub fn from_name(name: &str) -> Result<Stage, ScheduleError> {
        Stage::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or_else(|| ScheduleError::UnknownStage(name.to_string()))
    }
}

/// A system: one step of a tick, over the data its type declares.
///
/// ```
/// use remembrane_core::engine::resources::{Res, ResMut};
/// use remembrane_core::engine::schedule::System;
/// use remembrane_core::engine::simulation::{Clock, SimError};
///
/// /// Counts ticks that reached a simulated time of one millisecond.
/// struct LateTicks(u64);
/// struct LateTickCount(u64);
///
/// impl System for LateTicks {
///     type Data<'a> = (Res<'a, Clock>, ResMut<'a, LateTickCount>);
///     fn name(&self) -> &str {
///         "late_ticks"
///     }
///     fn run(&mut self, (clock, mut count): Self::Data<'_>) -> Result<(), SimError> {
///         if clock.time > 1e-3 {
///             count.0 += 1;
///         }
///         Ok(())
///     }
/// }
/// ```
///
/// A write that the type does not declare does not compile: a [`Res`]
/// gives no mutable access, and there is no other way to reach a resource.
///
/// ```compile_fail,E0594
/// use remembrane_core::engine::resources::Res;
/// use remembrane_core::engine::schedule::System;
/// use remembrane_core::engine::simulation::{Clock, SimError};
///
/// struct Sneaky;
///
/// impl System for Sneaky {
///     type Data<'a> = Res<'a, Clock>;
///     fn name(&self) -> &str {
///         "sneaky"
///     }
///     fn run(&mut self, mut clock: Self::Data<'_>) -> Result<(), SimError> {
///         clock.iteration += 1; // declared as a read
///         Ok(())
///     }
/// }
/// ```
///
/// [`Res`]: crate::engine::resources::Res
pub trait System: Send + 'static {
    /// The resources the system reads ([`Res`](crate::engine::resources::Res)) and
    /// writes ([`ResMut`](crate::engine::resources::ResMut)).
    type Data<'a>: SystemData<'a>;
    /// Unique name (used in ordering constraints, timings and errors).
    fn name(&self) -> &str;
    /// Runs the system.
    fn run(&mut self, data: Self::Data<'_>) -> Result<(), SimError>;
    /// For a system that runs several named parts (the force terms): each
    /// part's own accumulated time, reported in the timing table in place
    /// of the system's. Empty (the default): the system is timed as a whole.
    fn sub_timings(&self) -> Vec<(String, Duration)> {
        Vec::new()
    }
    /// The system's own state that carries over from one tick to the next,
    /// for checkpoints (`remembrane run --checkpoint-every`). `None` (the
    /// default) means it keeps none; scratch buffers refilled every tick do
    /// not count. A system that keeps state must return it here and take it
    /// back in `restore_state`, or a resumed run would differ from an
    /// uninterrupted one.
    fn save_state(&self) -> Option<serde_json::Value> {
        None
    }
    /// Takes back what `save_state` returned (on resuming a run).
    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError> {
        let _ = state;
        Err(crate::engine::error::StateError::Stateless)
    }
}

/// A system whose access is known only at run time (a scripted term, a
/// system configured from text). Every borrow through its
/// [`CheckedResources`] is checked against [`DynamicSystem::access`]: an
/// undeclared one fails the tick with [`SimError::Resource`].
pub trait DynamicSystem: Send + 'static {
    /// Unique name.
    fn name(&self) -> &str;
    /// What the system reads and writes.
    fn access(&self) -> Access;
    /// Runs the system.
    fn run(&mut self, resources: &CheckedResources<'_>) -> Result<(), SimError>;
    /// The system's own state that carries over from one tick to the next,
    /// for checkpoints (`remembrane run --checkpoint-every`). `None` (the
    /// default) means it keeps none; scratch buffers refilled every tick do
    /// not count. A system that keeps state must return it here and take it
    /// back in `restore_state`, or a resumed run would differ from an
    /// uninterrupted one.
    fn save_state(&self) -> Option<serde_json::Value> {
        None
    }
    /// Takes back what `save_state` returned (on resuming a run).
    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError> {
        let _ = state;
        Err(crate::engine::error::StateError::Stateless)
    }
}

/// A system as the schedule stores it.
pub(crate) trait ErasedSystem: Send {
    fn name(&self) -> &str;
    fn access(&self) -> Access;
    fn run(&mut self, resources: &Resources, access: &Access) -> Result<(), SimError>;
    fn sub_timings(&self) -> Vec<(String, Duration)> {
        Vec::new()
    }
    fn save_state(&self) -> Option<serde_json::Value>;
    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError>;
}

pub(crate) struct Typed<S>(pub S);

impl<S: System> ErasedSystem for Typed<S> {
    fn save_state(&self) -> Option<serde_json::Value> {
        self.0.save_state()
    }
    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError> {
        self.0.restore_state(state)
    }
    fn name(&self) -> &str {
        self.0.name()
    }
    fn sub_timings(&self) -> Vec<(String, Duration)> {
        self.0.sub_timings()
    }
    fn access(&self) -> Access {
        let mut access = Access::default();
        <S::Data<'_> as SystemData<'_>>::declare(&mut access);
        access
    }
    fn run(&mut self, resources: &Resources, _: &Access) -> Result<(), SimError> {
        let data = <S::Data<'_> as SystemData<'_>>::fetch(resources).map_err(|source| {
            SimError::Resource {
                system: self.0.name().to_string(),
                source,
            }
        })?;
        self.0.run(data)
    }
}

pub(crate) struct Dynamic<S>(pub S);

impl<S: DynamicSystem> ErasedSystem for Dynamic<S> {
    fn save_state(&self) -> Option<serde_json::Value> {
        self.0.save_state()
    }
    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError> {
        self.0.restore_state(state)
    }
    fn name(&self) -> &str {
        self.0.name()
    }
    fn access(&self) -> Access {
        self.0.access()
    }
    fn run(&mut self, resources: &Resources, access: &Access) -> Result<(), SimError> {
        self.0.run(&CheckedResources::new(resources, access))
    }
}

pub(crate) struct Entry {
    stage: Stage,
    system: Box<dyn ErasedSystem>,
    access: Access,
    before: Vec<String>,
    after: Vec<String>,
}

/// Registration handle returned by [`ScheduleBuilder::add`] for ordering.
pub struct Registered<'a> {
    entry: &'a mut Entry,
}

impl Registered<'_> {
    /// Run before the system named `other` (same stage).
    pub fn before(self, other: &str) -> Self {
        self.entry.before.push(other.to_string());
        self
    }

    /// Run after the system named `other` (same stage).
    pub fn after(self, other: &str) -> Self {
        self.entry.after.push(other.to_string());
        self
    }
}

/// Collects systems; [`ScheduleBuilder::build`] validates and orders them.
#[derive(Default)]
pub struct ScheduleBuilder {
    entries: Vec<Entry>,
    /// Stages whose systems may write only the listed resources, as the
    /// plugin that owns each stage's contract declared it
    /// ([`ScheduleBuilder::restrict_writes`]).
    write_limits: Vec<(Stage, Vec<ResourceId>)>,
}

impl ScheduleBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a typed `system` to `stage`; returns a handle for before/after
    /// constraints.
    pub fn add(&mut self, stage: Stage, system: impl System) -> Registered<'_> {
        self.push(stage, Box::new(Typed(system)))
    }

    /// Adds a dynamic `system` to `stage`.
    pub fn add_dynamic(&mut self, stage: Stage, system: impl DynamicSystem) -> Registered<'_> {
        self.push(stage, Box::new(Dynamic(system)))
    }

    fn push(&mut self, stage: Stage, system: Box<dyn ErasedSystem>) -> Registered<'_> {
        let access = system.access();
        self.entries.push(Entry {
            stage,
            system,
            access,
            before: Vec::new(),
            after: Vec::new(),
        });
        let entry = self.entries.last_mut().expect("just pushed");
        Registered { entry }
    }

    /// Lets the systems of `stage` write only `allowed` (added to what an
    /// earlier call allowed): the core plugin keeps the Forces stage to the
    /// force buffers, so that every force is reported and checked.
    pub fn restrict_writes(&mut self, stage: Stage, allowed: &[ResourceId]) {
        match self.write_limits.iter_mut().find(|(s, _)| *s == stage) {
            Some((_, list)) => list.extend_from_slice(allowed),
            None => self.write_limits.push((stage, allowed.to_vec())),
        }
    }

    /// Names of the registered systems, in registration order.
    pub fn names(&self) -> Vec<String> {
        self.entries
            .iter()
            .map(|e| e.system.name().to_string())
            .collect()
    }

    /// Validates the systems against `resources` and fixes their order.
    pub fn build(self, resources: &Resources) -> Result<Schedule, ScheduleError> {
        let mut seen = HashMap::new();
        for e in &self.entries {
            let name = e.system.name().to_string();
            if seen.insert(name.clone(), ()).is_some() {
                return Err(ScheduleError::DuplicateName(name));
            }
            let a = &e.access;
            for (k, id) in a.writes.iter().enumerate() {
                if a.reads.contains(id) || a.writes[..k].contains(id) {
                    return Err(ScheduleError::ConflictingAccess {
                        system: name,
                        resource: *id,
                    });
                }
            }
            if let Some(id) = a
                .reads
                .iter()
                .chain(&a.writes)
                .find(|id| !a.optional.contains(id) && !resources.contains_id(**id))
            {
                let available: Vec<&str> = resources.ids().iter().map(|i| i.name()).collect();
                return Err(ScheduleError::MissingResource {
                    system: name,
                    resource: *id,
                    available: available.join(", "),
                });
            }
            for (stage, allowed) in self.write_limits.iter().filter(|(s, _)| *s == e.stage) {
                if let Some(&resource) = a.writes.iter().find(|d| !allowed.contains(d)) {
                    let allowed: Vec<&str> = allowed.iter().map(|i| i.name()).collect();
                    return Err(ScheduleError::StageWrites {
                        system: name,
                        stage: stage.name(),
                        resource: resource.name(),
                        allowed: allowed.join(", "),
                    });
                }
            }
        }
        let mut entries = self.entries;
        let mut ordered: Vec<Entry> = Vec::with_capacity(entries.len());
        for stage in Stage::ALL {
            let mut in_stage: Vec<Entry> = Vec::new();
            let mut rest = Vec::new();
            for e in entries {
                if e.stage == stage {
                    in_stage.push(e);
                } else {
                    rest.push(e);
                }
            }
            entries = rest;
            ordered.extend(order_stage(stage, in_stage)?);
        }
        let timings = vec![Duration::ZERO; ordered.len()];
        Ok(Schedule {
            entries: ordered,
            timings,
            ticks: 0,
        })
    }
}

/// Topological order of one stage's systems (stable: ties keep
/// registration order).
fn order_stage(stage: Stage, entries: Vec<Entry>) -> Result<Vec<Entry>, ScheduleError> {
    let n = entries.len();
    let index: HashMap<String, usize> = entries
        .iter()
        .enumerate()
        .map(|(i, e)| (e.system.name().to_string(), i))
        .collect();
    // edges[a] contains b: a runs before b.
    let mut edges = vec![Vec::new(); n];
    for (i, e) in entries.iter().enumerate() {
        for (other, forward) in e
            .before
            .iter()
            .map(|o| (o, true))
            .chain(e.after.iter().map(|o| (o, false)))
        {
            let &j = index
                .get(other)
                .ok_or_else(|| ScheduleError::UnknownOrderTarget {
                    system: e.system.name().to_string(),
                    other: other.clone(),
                    stage: stage.name(),
                })?;
            if forward {
                edges[i].push(j);
            } else {
                edges[j].push(i);
            }
        }
    }
    let mut indegree = vec![0usize; n];
    for targets in &edges {
        for &j in targets {
            indegree[j] += 1;
        }
    }
    let mut order = Vec::with_capacity(n);
    let mut done = vec![false; n];
    while order.len() < n {
        let Some(next) = (0..n).find(|&i| !done[i] && indegree[i] == 0) else {
            let systems: Vec<&str> = (0..n)
                .filter(|&i| !done[i])
                .map(|i| entries[i].system.name())
                .collect();
            return Err(ScheduleError::Cycle {
                stage: stage.name(),
                systems: systems.join(", "),
            });
        };
        done[next] = true;
        order.push(next);
        for &j in &edges[next] {
            indegree[j] -= 1;
        }
    }
    let mut slots: Vec<Option<Entry>> = entries.into_iter().map(Some).collect();
    Ok(order
        .into_iter()
        .map(|i| slots[i].take().expect("each index once"))
        .collect())
}

/// A validated, ordered list of systems with their accumulated run times.
pub struct Schedule {
    entries: Vec<Entry>,
    timings: Vec<Duration>,
    ticks: u64,
}

/// Time spent in one system over a run.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SystemTiming {
    /// System name.
    pub system: String,
    /// Stage name.
    pub stage: String,
    /// Total wall time (s).
    pub total_s: f64,
    /// Mean wall time per tick (µs).
    pub per_tick_us: f64,
    /// Share of the time spent in all systems.
    pub share: f64,
    /// For a named part of a system (a force term of `force_terms`), that
    /// system. Parts may run concurrently, so their times can overlap and
    /// add up to more than their system's own row: the rows without
    /// `part_of` add up to the whole time.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub part_of: Option<String>,
}

impl Schedule {
    /// Runs one tick: every system in order. Stops at the first error.
    pub fn run_tick(&mut self, resources: &Resources) -> Result<(), SimError> {
        self.run_stages(&Stage::ALL, resources)?;
        self.ticks += 1;
        Ok(())
    }

    /// Runs the systems of `stages` only, in schedule order (e.g. Gather and
    /// Forces to evaluate the forces of the current state). Their time is
    /// added to their timings.
    pub fn run_stages(&mut self, stages: &[Stage], resources: &Resources) -> Result<(), SimError> {
        for (entry, time) in self.entries.iter_mut().zip(self.timings.iter_mut()) {
            if !stages.contains(&entry.stage) {
                continue;
            }
            let start = Instant::now();
            let result = entry.system.run(resources, &entry.access);
            *time += start.elapsed();
            result?;
        }
        Ok(())
    }

    /// The state every stateful system keeps between ticks, by system name
    /// (see [`System::save_state`]).
    pub fn save_states(&self) -> std::collections::BTreeMap<String, serde_json::Value> {
        self.entries
            .iter()
            .filter_map(|e| Some((e.system.name().to_string(), e.system.save_state()?)))
            .collect()
    }

    /// Gives every stateful system its saved state back. `saved` must name
    /// only systems of this schedule, and every system that keeps state.
    pub fn restore_states(
        &mut self,
        saved: &std::collections::BTreeMap<String, serde_json::Value>,
    ) -> Result<(), crate::engine::persisted::PersistError> {
        use crate::engine::persisted::PersistError;
        for e in &mut self.entries {
            let name = e.system.name().to_string();
            match saved.get(&name) {
                Some(state) => e
                    .system
                    .restore_state(state.clone())
                    .map_err(|source| PersistError::System { name, source })?,
                None if e.system.save_state().is_some() => {
                    return Err(PersistError::MissingSystemState(name));
                }
                None => {}
            }
        }
        if let Some(unknown) = saved
            .keys()
            .find(|k| self.entries.iter().all(|e| e.system.name() != k.as_str()))
        {
            return Err(PersistError::UnknownSystem(unknown.clone()));
        }
        Ok(())
    }

    /// The declared access of the system named `name`.
    pub fn access(&self, name: &str) -> Option<&Access> {
        self.entries
            .iter()
            .find(|e| e.system.name() == name)
            .map(|e| &e.access)
    }

    /// System names in run order, with their stages.
    pub fn order(&self) -> Vec<(Stage, String)> {
        self.entries
            .iter()
            .map(|e| (e.stage, e.system.name().to_string()))
            .collect()
    }

    /// Per-system timing table.
    ///
    /// A system with named parts ([`System::sub_timings`], the force terms)
    /// is listed with its own wall time, then part by part (`part_of` set).
    /// Shares are of the wall time of all systems: the systems' rows add up
    /// to 1; parts that ran concurrently overlap, so theirs may add up to
    /// more than their system's.
    pub fn timings(&self) -> Vec<SystemTiming> {
        let total: f64 = self.timings.iter().map(Duration::as_secs_f64).sum();
        let ticks = self.ticks.max(1) as f64;
        let row =
            |system: String, stage: Stage, t: &Duration, part_of: Option<&str>| SystemTiming {
                system,
                stage: stage.name().to_string(),
                total_s: t.as_secs_f64(),
                per_tick_us: t.as_secs_f64() / ticks * 1e6,
                share: if total > 0.0 {
                    t.as_secs_f64() / total
                } else {
                    0.0
                },
                part_of: part_of.map(str::to_string),
            };
        let mut rows = Vec::new();
        for (e, t) in self.entries.iter().zip(&self.timings) {
            let name = e.system.name();
            rows.push(row(name.to_string(), e.stage, t, None));
            let parts = e.system.sub_timings();
            rows.extend(
                parts
                    .iter()
                    .map(|(part, d)| row(part.clone(), e.stage, d, Some(name))),
            );
        }
        rows
    }

    /// The timing table as aligned text.
    pub fn timing_table(&self) -> String {
        format_timings(&self.timings())
    }
}

/// A timing table as aligned text (system, stage, total, per tick, share).
pub fn format_timings(timings: &[SystemTiming]) -> String {
    let mut s = format!(
        "{:<24} {:<13} {:>10} {:>12} {:>7}\n",
        "system", "stage", "total s", "µs/tick", "share"
    );
    for t in timings {
        let name = match &t.part_of {
            Some(_) => format!("  {}", t.system),
            None => t.system.clone(),
        };
        s += &format!(
            "{:<24} {:<13} {:>10.3} {:>12.2} {:>6.1}%\n",
            name,
            t.stage,
            t.total_s,
            t.per_tick_us,
            100.0 * t.share
        );
    }
    if timings.iter().any(|t| t.part_of.is_some()) {
        s += "(indented rows: parts of the system above them, which may run concurrently and \
              overlap; the other rows add up to the whole)\n";
    }
    s
}
