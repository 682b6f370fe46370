//! Protein species on the membrane: area fractions φ that couple to the
//! curvature, bind, interact and mix (SPEC §9). [`params`] declares them
//! with their units; [`free_energy`] is their free energy on the mesh with
//! its analytic derivatives against the shape and the fields; [`relax`]
//! minimises it over the fields at a fixed shape, on what the proteins feel
//! of the surface: its areas and curvatures in the bending's discretisation
//! ([`crate::energy::bending_measure`]). [`state`] keeps the
//! proteins' amounts on the vertices; [`term`] is the force term;
//! [`model`] holds the resources of a simulation with species.

pub mod free_energy;
pub(crate) mod measured;
pub mod model;
pub mod params;
pub mod relax;
pub mod remap;
pub mod state;
pub mod term;
pub mod transport;
