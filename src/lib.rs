//! remembrane: closed triangulated membranes moved by overdamped Langevin
//! dynamics under their free energy, with free-energy-controlled remeshing.
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
//! - **Typed resources** ([`resources`]) hold everything else, one value per type, each
//!   inserted by the plugin that owns it. Derived caches ([`Topology`]: entity → dense slot, dense
//!   edge/face arrays, ordered 1-rings in fixed-size blocks per vertex) are updated edit by edit
//!   for the edited patch only ([`topology_update`]; debug builds and every test compare the
//!   result with a full rebuild after each edit).
//! - **Systems** ([`schedule`]) name their data in their type: `type Data<'a> = (Res<'a,
//!   Clock>, ResMut<'a, DensePositions>, Option<Res<'a, VinSegmentation>>)` ([`System`], [`Res`],
//!   [`ResMut`]). The schedule derives
//!   the access from that type, so declarations cannot drift and a system cannot reach anything it
//!   did not declare. Before tick 0 it rejects: a resource no plugin inserted, one resource borrowed
//!   twice with a write, a Forces-stage system writing anything but [`ForceBuffers`], duplicate
//!   names, unknown ordering targets, cycles. [`DynamicSystem`]s (access known only at run time) get a
//!   view that fails any undeclared borrow.
//! - **Force terms** implement [`force::ForceTerm`] (name, energy, *add* −∇E into a buffer).
//!   [`SimBuilder::add_force_term`] (or [`Simulation::add_force_term`] before the first tick) registers
//!   the term's buffer in [`ForceBuffers`]; the core `force_terms` system ([`force_term_system`])
//!   evaluates every registered
//!   term, so every term is finite-checked, timed (under its own name), summed, used by the time
//!   step and reported alike. Terms are independent, so on a large mesh with more than one thread
//!   they run concurrently.
//! - **Recorders** ([`recorder`]) produce each frame's series columns and VTK point data; the
//!   run's `frames` system calls them in the Observe stage, which sees the last completed
//!   iteration's state with the forces its next step applies (no second force evaluation).
//! - **Checkpoints** ([`checkpoint`]) save what carries from one tick to the next and nothing
//!   else: the world entity by entity with hecs' free list ([`world_snapshot`]), the resources
//!   their plugins declared persistent ([`SimBuilder::persist_resource`], [`persisted`]), and
//!   the own state of systems, force terms and recorders (`save_state` / `restore_state`, default:
//!   none). Everything else is rebuilt from the scene or recomputed by the next tick.
//! - **Remeshing** dispatches on [`remesh::EdgeOp`] ([`Split`](remesh::EdgeOp::Split),
//!   [`Merge`](remesh::EdgeOp::Merge)), each with a feasibility check
//!   and an edit on the check-then-act edit layer ([`edit`]). Every per-vertex field has a
//!   transfer policy ([`vertex_field::TransferPolicy`]: [`Conserve`](vertex_field::TransferPolicy::Conserve)
//!   for lipid density, [`Interpolate`](vertex_field::TransferPolicy::Interpolate)
//!   for intensive fields such as protein coverage).
//! - **Scenes** name plugins: `Custom(name: "...", params: (...))` in `energy`, and `systems:
//!   [Custom(name, stage, params)]`, resolved through a [`registry::PluginRegistry`] while the scene
//!   is parsed. [`cli::main_with`]`(registry)` gives a user's binary the whole CLI.
//! - **Folders.** [`util`] (parallel loops, random streams, validators), [`analysis`] (measuring
//!   a run), [`workflow`] (runs, protocols, sweeps, collection, comparison, the shape diagram),
//!   [`study`] (speed against error on problems with independent answers, and the axisymmetric
//!   reference solver); the rest of `src/` is still flat, to be moved by role.
//! - **Layers.** The core ([`resources`], [`schedule`], [`simulation`], [`force`], [`membrane`],
//!   [`topology`], [`energy`], [`remesh`], [`edit`], [`recorder`], [`vertex_field`]) never imports
//!   `systems/`; `systems/` ([`systems`], mounted with `#[path]`, one system per file, plugins in
//!   [`systems::plugins`]) uses only the public API; [`scene`], [`workflow`], [`output`] and [`cli`] sit
//!   on top.
//!
//! One tick, in stage order ([`Stage`]; what each stage's built-in systems read → write):
//!
//! | stage | systems | resources written |
//! |---|---|---|
//! | Prepare | [`control_point_schedule`](systems::control_point_schedule) (when scheduled) | control points in [`Membrane`] |
//! | Gather | [`gather_state`](systems::gather_state), [`face_geometry`](systems::face_geometry), [`vin_edge_samples`](systems::vin_edge_samples) (with V_in) | [`Membrane`] (topology cache), [`DensePositions`], [`DenseLipid`], [`FaceGeometry`], zeroed [`ForceBuffers`], [`VinEdgeSamples`] (each edge's vector, length and V_in segment, read by the V_in force and the time step) |
//! | Forces | `force_terms` (every term: `vin`, `bending`, `volume`, `area`, `local_tension`, `springs`, plugins' terms, each timed under its name), then [`force_total`](systems::force_total), then [`constraint_reactions`](systems::constraint_reactions) (with `constraints`) | [`ForceBuffers`] only |
//! | Observe | `frames` (in runs: the recorders) | [`RunOutput`] |
//! | TimeStep | [`adaptive_time_step`](systems::adaptive_time_step) | [`TimeStepChoice`] |
//! | Integrate | [`langevin_integration`](systems::langevin_integration) (fold and inside-out checks), or [`fire_minimiser`](systems::fire_minimiser) with `method: Minimise`; then [`constraint_projection`](systems::constraint_projection) (with `constraints`) | [`DensePositions`], [`Membrane`] (positions, forces), [`Clock`]; the minimiser also [`MinimiserStatus`], [`StopRequest`] |
//! | BarrierCheck | [`barrier_check`](systems::barrier_check) | [`AbnormalEdges`] |
//! | Remesh | [`remesh`](systems::remesh) (when declared) | [`Membrane`], [`DensePositions`], [`DenseLipid`], [`AbnormalEdges`], [`RemeshStats`], [`RemeshTriggered`] |
//! | Remesh | [`edge_flips`](systems::edge_flips) (when declared; after `remesh`) | [`Membrane`] (faces and edges only), [`FlipStats`] |
//! | Diffuse | [`lipid_diffusion`](systems::lipid_diffusion) (when declared), plugins' systems | [`DenseLipid`], [`Membrane`] |
//!
//! The plugins and the resources they insert:
//!
//! | plugin ([`systems::plugins`]) | resources | systems |
//! |---|---|---|
//! | `core` | [`Clock`], [`DensePositions`], [`DenseLipid`], [`ForceBuffers`], [`FaceGeometry`], [`TimeStepChoice`], [`DynamicsParams`], [`RemeshParams`], [`AbnormalEdges`], [`Seed`], [`CheckInvariants`] | gather, face geometry, force total, time step, integration, barrier check |
//! | `vin` | [`VinSegmentation`], [`VinEdgeSamples`] | `vin_edge_samples`, term `vin` (unless the geometric baseline) |
//! | `bending`, `volume`, `area`, `local_tension`, `springs`, `self_avoidance` | — | their term |
//! | `constraints` | [`Constraints`] | `constraint_reactions`, `constraint_projection` |
//! | `control_points` | control-point entities | `control_point_schedule` |
//! | `remesh` | [`ValenceRange`], [`RemeshStats`], [`RemeshTriggered`] | `remesh` |
//! | `edge_flips` | [`ValenceRange`], [`FlipStats`] | `edge_flips` |
//! | `diffusion` | — | `lipid_diffusion` |
//! | `recorders` | [`Recorders`] | — (the run's `frames` system calls them) |
//!
//! The plugin guide (`docs/plugins.md`: a force term, a resource, a system and a registry entry,
//! declared by a scene) is compiled and run as a doctest.
//!
//! [`Membrane`]: membrane::Membrane
//! [`Position`]: components::Position
//! [`Force`]: components::Force
//! [`LipidDensity`]: components::LipidDensity
//! [`Topology`]: topology::Topology
//! [`System`]: schedule::System
//! [`DynamicSystem`]: schedule::DynamicSystem
//! [`Stage`]: schedule::Stage
//! [`Res`]: resources::Res
//! [`ResMut`]: resources::ResMut
//! [`ForceBuffers`]: force::ForceBuffers
//! [`FaceGeometry`]: force::FaceGeometry
//! [`SimBuilder::add_force_term`]: simulation::SimBuilder::add_force_term
//! [`Simulation::add_force_term`]: simulation::Simulation::add_force_term
//! [`SimBuilder::persist_resource`]: simulation::SimBuilder::persist_resource
//! [`Clock`]: core_resources::Clock
//! [`DensePositions`]: core_resources::DensePositions
//! [`DenseLipid`]: core_resources::DenseLipid
//! [`StopRequest`]: core_resources::StopRequest
//! [`Seed`]: core_resources::Seed
//! [`CheckInvariants`]: core_resources::CheckInvariants
//! [`VinEdgeSamples`]: energy::vin::VinEdgeSamples
//! [`VinSegmentation`]: systems::vin_forces::VinSegmentation
//! [`RunOutput`]: output::RunOutput
//! [`TimeStepChoice`]: timestep::TimeStepChoice
//! [`MinimiserStatus`]: minimise::MinimiserStatus
//! [`AbnormalEdges`]: systems::barrier_check::AbnormalEdges
//! [`RemeshStats`]: remesh::RemeshStats
//! [`RemeshTriggered`]: systems::remesh::RemeshTriggered
//! [`FlipStats`]: systems::edge_flips::FlipStats
//! [`DynamicsParams`]: params::DynamicsParams
//! [`RemeshParams`]: params::RemeshParams
//! [`Constraints`]: constraint::Constraints
//! [`ValenceRange`]: mesh::invariants::ValenceRange
//! [`Recorders`]: recorder::Recorders

pub mod cell_list;
pub mod cli;
pub mod components;
pub mod constraint;
pub mod core_resources;
pub mod edge_flip;
pub mod edit;
pub mod energy;
pub mod error;
pub mod fluid;
pub mod geometry;
pub mod membrane;
pub mod mesh;
pub mod minimise;
pub mod output;
pub mod topology;
pub mod topology_update;
pub mod world_snapshot;

/// Writes `bytes` to `path` atomically: a temporary file in the same folder,
/// then a rename, so readers never see a partial file.
pub fn atomic_write(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    atomic_write_with(path, |w| std::io::Write::write_all(w, bytes))
}

/// Writes `path` atomically from `write`, which streams into a buffered
/// temporary file in the same folder that is renamed to `path` once complete
/// (and removed if `write` fails), so a large file is never held in memory
/// whole and readers never see a partial one.
pub fn atomic_write_with<E: From<std::io::Error>>(
    path: &std::path::Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> Result<(), E>,
) -> Result<(), E> {
    use std::io::Write;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let written = (|| {
        let mut file = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        write(&mut file)?;
        file.flush()?;
        std::fs::rename(&tmp, path)?;
        Ok(())
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

pub mod checkpoint;
pub mod fd;
pub mod force;
pub mod force_term_system;
pub mod params;
pub mod persisted;

pub mod analysis;
pub mod plot;
pub mod plugin_decl;
pub mod quality;
pub mod recorder;
pub mod registry;
pub mod relax;
pub mod remesh;
pub mod render;
pub mod report;
pub mod resolution;
pub mod resources;
pub mod run_dir;
pub mod scene;
pub mod scene_override;
pub mod schedule;
pub mod setting;
pub mod simulation;
pub mod state;
pub mod study;
#[path = "../systems/mod.rs"]
pub mod systems;
pub mod timestep;
pub mod util;
pub mod vertex_field;
pub mod workflow;

#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

/// The plugin guide, `docs/plugins.md`: its Rust code is compiled and run
/// as a doctest.
#[doc = include_str!("../docs/plugins.md")]
#[cfg(doctest)]
pub struct PluginGuideDoctests;
