//! The remembrane engine core: the membrane, the ECS engine and the physics
//! kernels, with no systems, no scene format and no command line.
//!
//! The crate `remembrane` re-exports every module here under the same name
//! (`remembrane::mesh`, `remembrane::engine`, ...), and its crate
//! documentation describes the whole architecture. The built-in systems are
//! the crate `remembrane_systems` (the repository's `systems/` folder), which
//! uses only this crate's public API, as a user's plugin does.
//!
//! The folders, lowest first (each uses only those before it, except where
//! a kernel names the parameters it reads):
//! - [`util`]: deterministic parallel loops, seeded random streams, serde
//!   validators, atomic writes;
//! - [`mesh`]: meshes, the world's components, the topology cache, the
//!   check-then-act edit layer, geometry, mesh files;
//! - [`engine`]: typed resources, the schedule, the simulation and its
//!   builder, the force-term interface, recorders, persisted resources;
//! - [`energy`]: each force term in its own file (parameters, kernel,
//!   `ForceTerm`, plugin), and the shared penalty kernels;
//! - [`remesh`]: split/merge events, relaxation, Metropolis flips;
//! - [`params`]: the scene's parameters by part;
//! - [`constraint`], [`fluid`], [`minimise`], [`timestep`]: exact
//!   constraints, the fluid membrane's projection, the minimiser's state and
//!   the adaptive step; [`fd`]: finite-difference checks of every force;
//! - [`species`]: protein species (their parameters, their free energy).

pub mod constraint;
pub mod diffusion;
pub mod energy;
pub mod engine;
pub mod fd;
pub mod fluid;
pub mod mesh;
pub mod minimise;
pub mod params;
pub mod remesh;
pub mod species;
pub mod timestep;
pub mod util;

pub use util::atomic_write::{atomic_write, atomic_write_with};
