//! remembrane: triangulated membranes, closed or open, moved by overdamped
//! Langevin dynamics or brought to equilibrium by a minimiser under their
//! free energy, with free-energy-controlled remeshing.
//!
//! This is the engine's architecture. How to run it, the scene files and the guides (protocols,
//! checkpoints, the minimiser, the fluid model, thermal runs, the study, plugins) are in the
//! repository's `README.md` and `docs/`; measured results in `benches/RESULTS.md`.
//!
//! # Architecture
//!
//! Built-in physics is a list of plugins, registered through exactly the API a user's crate uses.
//!
//! - **The hecs `World` is the source of truth** (inside the [`Membrane`] resource). Vertex entities
//!   carry [`Position`], [`Force`] and one component per registered per-vertex field ([`LipidDensity`]
//!   only when the scene declares it); edge entities reference their two vertices and two faces;
//!   face entities their three vertices and edges; control points are their own entities.
//! - **Typed resources** ([`resources`](engine::resources)) hold everything else, one value per type, each
//!   inserted by the plugin that owns it. Derived caches ([`Topology`]: entity → dense slot, dense
//!   edge/face arrays, ordered 1-rings in fixed-size blocks per vertex) are updated edit by edit
//!   for the edited patch only ([`topology_update`](mesh::topology_update); debug builds and every test compare the
//!   result with a full rebuild after each edit).
//! - **Systems** ([`schedule`](engine::schedule)) name their data in their type: `type Data<'a> = (Res<'a,
//!   Clock>, ResMut<'a, DensePositions>, Option<Res<'a, VinSegmentation>>)` ([`System`], [`Res`],
//!   [`ResMut`]). The schedule derives
//!   the access from that type, so declarations cannot drift and a system cannot reach anything it
//!   did not declare. [`SimBuilder::build`] seals the simulation: it validates and orders the
//!   schedule, and returns an error instead of a [`Simulation`] when it rejects: a resource no plugin inserted, one resource borrowed
//!   twice with a write, a Forces-stage system writing anything but [`ForceBuffers`] (a limit the
//!   core plugin declares, [`ScheduleBuilder::restrict_writes`]), duplicate
//!   names, unknown ordering targets, cycles. [`DynamicSystem`]s (access known only at run time) get a
//!   view that fails any undeclared borrow.
//! - **Force terms** implement [`engine::force::ForceTerm`] (name, energy, *add* −∇E into a buffer).
//!   [`SimBuilder::add_force_term`] registers
//!   the term's buffer in [`ForceBuffers`]; the `force_terms` system ([`force_terms`](systems::force_terms))
//!   evaluates every registered
//!   term, so every term is finite-checked, timed (under its own name), summed, used by the time
//!   step and reported alike. Terms are independent, so on a large mesh with more than one thread
//!   they run concurrently.
//! - **Recorders** ([`recorder`](engine::recorder)) produce each frame's series columns and VTK point data.
//!   Each is a typed Observe-stage system (`record_<name>`, its reads declared by its type), run
//!   when the `frame_clock` ([`frame_clock`](engine::frame_clock)) opens a frame. Observe sees the
//!   last completed iteration's state with the forces its next step applies (no second force
//!   evaluation); the `frames` system writes the frame in the Output stage. A scene's simulation
//!   has frame output from its build: a run only sets the [`FrameSchedule`] and opens the
//!   [`OpenOutput`] directory, both resources. A plugin can add its own section to
//!   `summary.json` the same way ([`summary_section`](engine::summary_section)); the adhered
//!   vesicle's report is one.
//! - **Checkpoints** ([`checkpoint`](io::checkpoint)) save what carries from one tick to the next and nothing
//!   else: the world entity by entity with hecs' free list ([`world_snapshot`](io::world_snapshot)), the resources
//!   their plugins declared persistent ([`SimBuilder::persist_resource`], [`persisted`](engine::persisted)), and
//!   the own state of systems, force terms and recorders (`save_state` / `restore_state`, default:
//!   none). Everything else is rebuilt from the scene or recomputed by the next tick.
//! - **Remeshing** dispatches on [`remesh::EdgeOp`] ([`Split`](remesh::EdgeOp::Split),
//!   [`Merge`](remesh::EdgeOp::Merge)), each with a feasibility check
//!   and an edit on the check-then-act edit layer ([`edit`](mesh::edit)). Every per-vertex field has a
//!   transfer policy ([`mesh::vertex_field::TransferPolicy`]: [`Conserve`](mesh::vertex_field::TransferPolicy::Conserve)
//!   for lipid density, [`Interpolate`](mesh::vertex_field::TransferPolicy::Interpolate)
//!   for intensive fields such as protein coverage).
//! - **Scenes** name plugins: `Custom(name: "...", params: (...))` in `energy`, and `systems:
//!   [Custom(name, stage, params)]`, resolved through a [`scene::registry::PluginRegistry`] while the scene
//!   is parsed. [`cli::main_with`]`(registry)` gives a user's binary the whole CLI.
//! - **Three crates, one API.** The engine core is the crate `remembrane_core` (`src/core/`):
//!   [`util`] (parallel loops, random streams, validators, atomic writes) → [`mesh`] (meshes,
//!   the world's components, topology, edits, geometry) → [`engine`] (resources, schedule,
//!   simulation, the force-term interface, recorders, summary sections, and the resources the
//!   built-in systems publish for each other, [`shared_resources`](engine::shared_resources))
//!   → [`energy`] (one file per term) → [`remesh`] (split/merge events, relaxation, flips),
//!   with [`params`] (the scene's parameters by part), [`constraint`], [`fluid`],
//!   [`minimise`], [`timestep`], [`diffusion`], [`species`] and [`fd`]. The built-in systems are the crate
//!   `remembrane_systems` (`systems/`, one system per file and nothing else), which depends
//!   on the core's public API only, as a user's plugin does; the core never imports it, and
//!   no system imports another. This crate (`src/`) sits on both: [`analysis`] (measuring a run's
//!   shapes, and the continuum references it is held against: axisymmetric shapes, the
//!   adhered vesicle) → [`io`] (run directories and their typed summary, frames, state,
//!   checkpoints, reports, plots, the built-in recorders) → [`scene`] (the file format,
//!   overrides, the plugin registry, and the scene build, the one place that assembles the
//!   built-in plugins, [`scene::plugins`]) → [`workflow`] (runs, protocols, sweeps,
//!   collection, comparison, the shape diagram) → [`study`] (speed against error) → [`cli`]
//!   (one file per group of commands). Each folder imports only the ones before it.
//!   It re-exports the core's modules and the systems under their names
//!   (`remembrane::mesh`, …, [`systems`]), so one path names every public item.
//!
//! One tick, in stage order ([`Stage`]; what each stage's built-in systems read → write):
//!
//! | stage | systems | resources written |
//! |---|---|---|
//! | Prepare | [`control_point_schedule`](systems::control_point_schedule) (when scheduled) | control points in [`Membrane`] |
//! | Gather | [`gather_state`](systems::gather_state), [`face_geometry`](systems::face_geometry), [`vin_edge_samples`](energy::vin_edge_samples) (with V_in), [`vertex_normals`](systems::vertex_normals) (the fluid model), [`species_gather`](systems::species_gather) and with the minimiser [`species_relaxation`](systems::species_relaxation) (with species: the fields relax at the current shape) | [`Membrane`] (topology cache), [`DensePositions`], [`DenseLipid`], [`FaceGeometry`], zeroed [`ForceBuffers`], [`TermInputs`] (what is measured once for the terms: with V_in its [`VinEdgeSamples`], each edge's vector, length and V_in segment, read by the V_in force and the time step), [`VertexNormals`] |
//! | Forces | `force_terms` (every term: `vin`, `bending`, `volume`, `area`, `local_tension`, `springs`, plugins' terms, each timed under its name), [`fluid_projection`](systems::fluid_projection) (the fluid model: the physical forces' tangential parts), then [`force_total`](systems::force_total), then [`pin_forces`](systems::pin_forces) (with held boundary vertices) and [`constraint_reactions`](systems::constraint_reactions) (with `constraints`: also the constraint gradients the minimiser uses) | [`ForceBuffers`] only |
//! | Observe | `frame_clock`, then the recorders (`record_state_columns`, `record_force`, …) | [`FrameSchedule`], [`CurrentFrame`] |
//! | Output | `frames` ([`FrameWriter`]: only when a run opened an output directory) | [`OpenOutput`] |
//! | TimeStep | [`adaptive_time_step`](systems::adaptive_time_step) | [`TimeStepChoice`] |
//! | Integrate | [`langevin_integration`](systems::langevin_integration) (fold and inside-out checks), or [`fire_minimiser`](systems::fire_minimiser) with `method: Minimise`; then [`pin_positions`](systems::pin_positions) (with held boundary vertices) and [`constraint_projection`](systems::constraint_projection) (with `constraints`) | [`DensePositions`], [`Membrane`] (positions, forces), [`Clock`]; the minimiser also [`MinimiserStatus`], [`StopRequest`] |
//! | BarrierCheck | [`barrier_check`](systems::barrier_check), in the fluid model's dynamics with species [`species_remap`](systems::species_remap) (the proteins stay in place under the step's slides) | [`AbnormalEdges`], [`Membrane`] (the species' amounts) |
//! | Remesh | [`maintenance_flips`](systems::maintenance_flips) (the fluid model's Delaunay flips; before `remesh`) | [`Membrane`] (faces and edges only), [`MaintenanceFlipStats`] |
//! | Remesh | [`remesh`](systems::remesh) (when declared) | [`Membrane`], [`DensePositions`], [`DenseLipid`], [`AbnormalEdges`], [`RemeshStats`], [`RemeshTriggered`] |
//! | Remesh | [`edge_flips`](systems::edge_flips) (when declared; after `remesh`) | [`Membrane`] (faces and edges only), [`FlipStats`] |
//! | Diffuse | [`lipid_diffusion`](systems::lipid_diffusion) (when declared), in overdamped dynamics [`species_transport`](systems::species_transport) (a species with a mobility or a binding rate), plugins' systems | [`DenseLipid`], [`Membrane`] (the species' amounts), [`SpeciesStatus`](species::model::SpeciesStatus) |
//!
//! The plugins and the resources they insert:
//!
//! | plugin ([`scene::plugins`]) | resources | systems |
//! |---|---|---|
//! | `core` | [`Clock`], [`DensePositions`], [`DenseLipid`], [`ForceBuffers`], [`FaceGeometry`], [`TimeStepChoice`], [`DynamicsParams`], [`RemeshParams`], [`AbnormalEdges`], [`Seed`], [`CheckInvariants`], [`StopRequest`]; [`MinimiserStatus`] with the minimiser | gather, face geometry, force terms, force total, time step and integration or the minimiser, barrier check |
//! | `vin` ([`energy::vin`]) | [`VinSegmentation`], [`VinEdgeSamples`] in [`TermInputs`] | `vin_edge_samples`, term `vin` (unless the geometric baseline) |
//! | each term's `plugin` in [`energy`] (`bending`, `volume`, `area`, `tension`, `local_tension`, `springs`, `self_avoidance`) | — | their term |
//! | `constraints` | [`Constraints`] | `constraint_reactions`, `constraint_projection` |
//! | `fluid` (`model: Fluid(...)`) | [`MembraneModel`], [`VertexNormals`] | `vertex_normals`, `fluid_projection` |
//! | `maintenance_flips` (the fluid model's `flips`) | [`ValenceRange`], [`MaintenanceFlipStats`] | `maintenance_flips` |
//! | `boundary_conditions` (open membranes' `boundary`) | [`PinnedVertices`] (when a loop is held) | `pin_forces`, `pin_positions`, term `line_tension` (when a free loop has one) |
//! | `control_points` | control-point entities | `control_point_schedule` |
//! | `remesh` | [`ValenceRange`], [`RemeshStats`], [`RemeshTriggered`] | `remesh` |
//! | `edge_flips` | [`ValenceRange`], [`FlipStats`] | `edge_flips` |
//! | `diffusion` | — | `lipid_diffusion` |
//! | `species` ([`species`]) | `ProteinAmount` components, [`SpeciesAmounts`](species::state::SpeciesAmounts) in [`TermInputs`], [`SpeciesModel`](species::model::SpeciesModel), [`SpeciesStatus`](species::model::SpeciesStatus) | `species_gather`, term `species`, `species_relaxation` (with the minimiser), `species_transport` (in overdamped dynamics), `species_remap` (the fluid model's dynamics), recorder `species` |
//! | `recorders` | [`FrameSchedule`], [`CurrentFrame`] | `frame_clock`, a `record_<name>` system per recorder (Observe) |
//! | `frame_output` ([`io::output::frame_output`]) | [`OpenOutput`] | `frames` (Output) |
//!
//! The plugin guide (`docs/plugins.md`: a force term, a resource, a system and a registry entry,
//! declared by a scene) is compiled and run as a doctest.
//!
//! [`Membrane`]: mesh::membrane::Membrane
//! [`Position`]: mesh::components::Position
//! [`Force`]: mesh::components::Force
//! [`LipidDensity`]: mesh::components::LipidDensity
//! [`Topology`]: mesh::topology::Topology
//! [`System`]: engine::schedule::System
//! [`DynamicSystem`]: engine::schedule::DynamicSystem
//! [`Stage`]: engine::schedule::Stage
//! [`ScheduleBuilder::restrict_writes`]: engine::schedule::ScheduleBuilder::restrict_writes
//! [`Res`]: engine::resources::Res
//! [`ResMut`]: engine::resources::ResMut
//! [`ForceBuffers`]: engine::force::ForceBuffers
//! [`FaceGeometry`]: engine::force::FaceGeometry
//! [`SimBuilder::add_force_term`]: engine::simulation::SimBuilder::add_force_term
//! [`SimBuilder::build`]: engine::simulation::SimBuilder::build
//! [`Simulation`]: engine::simulation::Simulation
//! [`SimBuilder::persist_resource`]: engine::simulation::SimBuilder::persist_resource
//! [`Clock`]: engine::core_resources::Clock
//! [`DensePositions`]: engine::core_resources::DensePositions
//! [`DenseLipid`]: engine::core_resources::DenseLipid
//! [`StopRequest`]: engine::core_resources::StopRequest
//! [`Seed`]: engine::core_resources::Seed
//! [`CheckInvariants`]: engine::core_resources::CheckInvariants
//! [`VinEdgeSamples`]: energy::vin::VinEdgeSamples
//! [`TermInputs`]: engine::term_inputs::TermInputs
//! [`VinSegmentation`]: energy::vin::VinSegmentation
//! [`OpenOutput`]: io::output::OpenOutput
//! [`FrameWriter`]: io::output::FrameWriter
//! [`FrameSchedule`]: engine::frame_clock::FrameSchedule
//! [`CurrentFrame`]: engine::frame_clock::CurrentFrame
//! [`TimeStepChoice`]: timestep::TimeStepChoice
//! [`MinimiserStatus`]: minimise::MinimiserStatus
//! [`AbnormalEdges`]: engine::shared_resources::AbnormalEdges
//! [`RemeshStats`]: remesh::RemeshStats
//! [`RemeshTriggered`]: engine::shared_resources::RemeshTriggered
//! [`FlipStats`]: engine::shared_resources::FlipStats
//! [`MaintenanceFlipStats`]: engine::shared_resources::MaintenanceFlipStats
//! [`VertexNormals`]: engine::shared_resources::VertexNormals
//! [`PinnedVertices`]: engine::shared_resources::PinnedVertices
//! [`MembraneModel`]: params::MembraneModel
//! [`DynamicsParams`]: params::DynamicsParams
//! [`RemeshParams`]: params::RemeshParams
//! [`Constraints`]: constraint::Constraints
//! [`ValenceRange`]: mesh::invariants::ValenceRange

pub mod analysis;
pub mod cli;
pub mod io;
pub mod scene;
pub mod study;
pub mod workflow;

// The engine core (`src/core`, crate `remembrane_core`) and the built-in
// systems (`systems/`, crate `remembrane_systems`), re-exported so that one
// path, `remembrane::…`, names every public item.
pub use remembrane_core::{atomic_write, atomic_write_with};
pub use remembrane_core::{
    constraint, diffusion, energy, engine, fd, fluid, mesh, minimise, params, remesh, species,
    timestep, util,
};
pub use remembrane_systems as systems;

#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

/// The plugin guide, `docs/plugins.md`: its Rust code is compiled and run
/// as a doctest.
#[doc = include_str!("../docs/plugins.md")]
#[cfg(doctest)]
pub struct PluginGuideDoctests;
