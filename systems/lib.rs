//! The built-in systems (crate `remembrane_systems`), one per file. Each
//! file's header states its stage, what it reads and what it writes.
//!
//! Only systems live here, written against the engine core's public API
//! (the crate `remembrane_core`) exactly as a user's system is: this crate
//! sees nothing the core keeps to itself, and the core never imports it.
//! A file exports its system (and its name in the schedule) and nothing
//! else, and no system imports another: what systems share lives in the
//! core (the resources they publish for each other in
//! `remembrane_core::engine::shared_resources`, kernels such as the step
//! check or the flips' Delaunay test in the core module of their concept).
//! The force terms are in the core's `energy`; the built-in recorders
//! (`remembrane::io::recorders`) and the built-in plugins that register
//! these systems (`remembrane::scene::plugins`, beside the scene build that
//! assembles them) are in the crate `remembrane`, which re-exports this one
//! as `remembrane::systems`.

pub mod adaptive_time_step;
pub mod barrier_check;
pub mod constraint_projection;
pub mod constraint_reactions;
pub mod control_point_schedule;
pub mod edge_flips;
pub mod face_geometry;
pub mod fire_minimiser;
pub mod fluid_projection;
pub mod force_terms;
pub mod force_total;
pub mod gather_state;
pub mod langevin_integration;
pub mod lipid_diffusion;
pub mod maintenance_flips;
pub mod pin_forces;
pub mod pin_positions;
pub mod remesh;
pub mod species_gather;
pub mod species_relaxation;
pub mod species_remap;
pub mod species_transport;
pub mod vertex_normals;
