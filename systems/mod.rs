//! The built-in systems, one per file. Each file's header states its stage,
//! what it reads and what it writes.
//!
//! These files are compiled into the library (mounted with `#[path]`), but
//! use only its public API: a user's system is written the same way. The
//! core (`simulation`, `schedule`, `force`, ...) never imports them; the
//! built-in plugins that register them are in [`plugins`].

pub mod adaptive_time_step;
pub mod area_forces;
pub mod barrier_check;
pub mod bending_forces;
pub mod constraint_projection;
pub mod constraint_reactions;
pub mod control_point_schedule;
pub mod edge_flips;
pub mod face_geometry;
pub mod fire_minimiser;
pub mod fluid_projection;
pub mod force_total;
pub mod gather_state;
pub mod langevin_integration;
pub mod lipid_diffusion;
pub mod local_tension_forces;
pub mod maintenance_flips;
pub mod plugins;
pub mod recorders;
pub mod remesh;
pub mod self_avoidance_forces;
pub mod spring_forces;
pub mod tension_forces;
pub mod vertex_normals;
pub mod vin_edge_samples;
pub mod vin_forces;
pub mod volume_forces;

pub use area_forces::AreaForces;
pub use bending_forces::BendingForces;
pub use local_tension_forces::LocalTensionForces;
pub use self_avoidance_forces::SelfAvoidanceForces;
pub use spring_forces::SpringForces;
pub use tension_forces::TensionForces;
pub use vin_forces::VinForces;
pub use volume_forces::VolumeForces;
