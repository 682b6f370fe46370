//! Energy-term kernels on dense arrays. The force systems in `systems/` wrap
//! them; each kernel returns the energy and, given a force buffer, adds −∇E.

pub mod bending;
pub mod bending_dihedral;
pub mod penalty;
pub mod self_avoidance;
pub mod springs;
pub mod tension;
pub mod vin;
pub mod vin_elasticity;
