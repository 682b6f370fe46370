//! Ordered systems: stages, registration with before/after constraints,
//! validation when the schedule is built, and per-system timing.
//!
//! A tick runs the stages in [`Stage::ALL`] order; within a stage, systems
//! run in registration order adjusted by their `before`/`after`
//! constraints. Built-in systems register through the same path as a
//! user's (see [`crate::simulation::Simulation::add_system`]).

use crate::simulation::{SimError, SimState};
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// The ordered stages of a tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Stage {
    /// Refresh caches, gather the dense state, apply scheduled changes.
    Prepare,
    /// Accumulate forces (systems here may write only force accumulators).
    Forces,
    /// Choose the time step.
    TimeStep,
    /// Move the vertices.
    Integrate,
    /// Detect edges that crossed a V_in barrier.
    BarrierCheck,
    /// Split and merge.
    Remesh,
    /// Lipid diffusion.
    Diffuse,
    /// Record observables and write outputs.
    Observe,
}

impl Stage {
    /// All stages in tick order.
    pub const ALL: [Stage; 8] = [
        Stage::Prepare,
        Stage::Forces,
        Stage::TimeStep,
        Stage::Integrate,
        Stage::BarrierCheck,
        Stage::Remesh,
        Stage::Diffuse,
        Stage::Observe,
    ];

    /// The stage's name as used in plugin registries and reports.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Prepare => "Prepare",
            Stage::Forces => "Forces",
            Stage::TimeStep => "TimeStep",
            Stage::Integrate => "Integrate",
            Stage::BarrierCheck => "BarrierCheck",
            Stage::Remesh => "Remesh",
            Stage::Diffuse => "Diffuse",
            Stage::Observe => "Observe",
        }
    }

    /// Parses a stage name (for registries that name stages in text).
    pub fn from_name(name: &str) -> Result<Stage, ScheduleError> {
        Stage::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or_else(|| ScheduleError::UnknownStage(name.to_string()))
    }
}

/// A data set a system reads or writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Data {
    /// Vertex positions (dense mirror and world).
    Positions,
    /// Per-term force buffers and the total force.
    ForceAccumulators,
    /// Per-face geometry shared by face-based force terms.
    FaceGeometry,
    /// The time step of the current tick.
    TimeStep,
    /// Simulated time and iteration count.
    Clock,
    /// Mesh connectivity (entities and the topology cache).
    Topology,
    /// Lipid density.
    LipidDensity,
    /// Control points.
    ControlPoints,
    /// Barrier-crossing (abnormal) edge lists.
    BarrierCrossings,
    /// Files written by the run.
    Output,
    /// A user-defined data set.
    Custom(&'static str),
}

/// What a system reads and writes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Access {
    /// Data sets read.
    pub reads: Vec<Data>,
    /// Data sets written.
    pub writes: Vec<Data>,
}

impl Access {
    /// Reads `reads`, writes `writes`.
    pub fn new(reads: &[Data], writes: &[Data]) -> Self {
        Self {
            reads: reads.to_vec(),
            writes: writes.to_vec(),
        }
    }
}

/// A system: one step of a tick.
pub trait System: Send {
    /// Unique name (used in ordering constraints, timings and errors).
    fn name(&self) -> &str;
    /// What the system reads and writes (checked when the schedule is built).
    fn access(&self) -> Access;
    /// Runs the system on the simulation state.
    fn run(&mut self, state: &mut SimState) -> Result<(), SimError>;
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
    /// A system in the Forces stage declares a write other than force accumulators.
    #[error(
        "force system `{system}` writes {data:?}; systems in the Forces stage may write only force accumulators"
    )]
    ForceSystemWrites {
        /// The system.
        system: String,
        /// The forbidden write.
        data: Data,
    },
}

struct Entry {
    stage: Stage,
    system: Box<dyn System>,
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
}

impl ScheduleBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `system` to `stage`; returns a handle for before/after constraints.
    pub fn add(&mut self, stage: Stage, system: Box<dyn System>) -> Registered<'_> {
        self.entries.push(Entry {
            stage,
            system,
            before: Vec::new(),
            after: Vec::new(),
        });
        let entry = self.entries.last_mut().expect("just pushed");
        Registered { entry }
    }

    /// Adds `system` to the stage named `stage` (for text registries).
    pub fn add_named(
        &mut self,
        stage: &str,
        system: Box<dyn System>,
    ) -> Result<Registered<'_>, ScheduleError> {
        let stage = Stage::from_name(stage)?;
        Ok(self.add(stage, system))
    }

    /// Names of the registered systems, in registration order.
    pub fn names(&self) -> Vec<String> {
        self.entries
            .iter()
            .map(|e| e.system.name().to_string())
            .collect()
    }

    /// Validates the systems and fixes their order.
    pub fn build(self) -> Result<Schedule, ScheduleError> {
        let mut seen = HashMap::new();
        for e in &self.entries {
            let name = e.system.name().to_string();
            if seen.insert(name.clone(), ()).is_some() {
                return Err(ScheduleError::DuplicateName(name));
            }
            let access = e.system.access();
            let forbidden = access
                .writes
                .iter()
                .find(|d| **d != Data::ForceAccumulators);
            if let (Stage::Forces, Some(&data)) = (e.stage, forbidden) {
                return Err(ScheduleError::ForceSystemWrites { system: name, data });
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
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SystemTiming {
    /// System name.
    pub system: String,
    /// Stage name.
    pub stage: &'static str,
    /// Total wall time (s).
    pub total_s: f64,
    /// Mean wall time per tick (µs).
    pub per_tick_us: f64,
    /// Share of the time spent in all systems.
    pub share: f64,
}

impl Schedule {
    /// Runs one tick: every system in order. Stops at the first error.
    pub fn run_tick(&mut self, state: &mut SimState) -> Result<(), SimError> {
        for (entry, time) in self.entries.iter_mut().zip(self.timings.iter_mut()) {
            let start = Instant::now();
            let result = entry.system.run(state);
            *time += start.elapsed();
            result?;
        }
        self.ticks += 1;
        Ok(())
    }

    /// System names in run order, with their stages.
    pub fn order(&self) -> Vec<(Stage, String)> {
        self.entries
            .iter()
            .map(|e| (e.stage, e.system.name().to_string()))
            .collect()
    }

    /// Per-system timing table.
    pub fn timings(&self) -> Vec<SystemTiming> {
        let total: f64 = self.timings.iter().map(Duration::as_secs_f64).sum();
        let ticks = self.ticks.max(1) as f64;
        self.entries
            .iter()
            .zip(&self.timings)
            .map(|(e, t)| SystemTiming {
                system: e.system.name().to_string(),
                stage: e.stage.name(),
                total_s: t.as_secs_f64(),
                per_tick_us: t.as_secs_f64() / ticks * 1e6,
                share: if total > 0.0 {
                    t.as_secs_f64() / total
                } else {
                    0.0
                },
            })
            .collect()
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
        s += &format!(
            "{:<24} {:<13} {:>10.3} {:>12.2} {:>6.1}%\n",
            t.system,
            t.stage,
            t.total_s,
            t.per_tick_us,
            100.0 * t.share
        );
    }
    s
}
