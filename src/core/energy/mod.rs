//! The built-in energy terms, one file each: its parameters (with units),
//! its kernel on dense arrays (the energy and, given a force buffer, −∇E
//! added to it), its [`ForceTerm`](crate::engine::force::ForceTerm) with
//! its flip pricing, and its plugin (`plugin`), shaped like a user's term
//! (the BAR-domain example). V_in's plugin, which also adds the Gather
//! system that measures its edges, is `remembrane::scene::plugins::vin`. Shared kernels: the penalty machinery
//! ([`penalty`]: volume, area and local-tension kernels, 1-ring
//! smoothing), the dihedral form of bending ([`bending_dihedral`]); and the in-plane
//! elasticity V_in gives a fixed mesh ([`vin_elasticity`], a measurement,
//! not a term).

pub mod area;
pub mod bending;
pub mod bending_dihedral;
pub mod local_tension;
pub mod penalty;
pub mod self_avoidance;
pub mod springs;
pub mod tension;
pub mod vin;
pub mod vin_elasticity;
pub mod volume;
