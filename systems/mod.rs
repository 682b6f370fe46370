//! The built-in systems, one per file. Each file's header states its stage,
//! what it reads and what it writes.
//!
//! Only systems live here: the force terms are in [`crate::energy`], the
//! built-in recorders in [`crate::io::recorders`], and the built-in plugins
//! that register the systems in [`crate::scene::plugins`], beside the scene
//! build that assembles them. These files are compiled into the library
//! (mounted with `#[path]`), but use only its public API: a user's system
//! is written the same way. The core (`simulation`, `schedule`, `force`,
//! ...) never imports them.

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
pub mod remesh;
pub mod vertex_normals;
pub mod vin_edge_samples;
