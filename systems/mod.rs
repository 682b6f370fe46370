//! The built-in systems, one per file. Each file's header states its stage,
//! what it reads and what it writes.
//!
//! These files are compiled into the library (mounted with `#[path]`), but
//! use only its public API: a user's system is written the same way.

pub mod area_forces;
pub mod bending_forces;
pub mod local_tension_forces;
pub mod spring_forces;
pub mod vin_forces;
pub mod volume_forces;

pub use area_forces::AreaForces;
pub use bending_forces::BendingForces;
pub use local_tension_forces::LocalTensionForces;
pub use spring_forces::SpringForces;
pub use vin_forces::VinForces;
pub use volume_forces::VolumeForces;
