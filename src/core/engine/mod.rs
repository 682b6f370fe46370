//! The ECS runtime and its plug-in interfaces: typed resources, the
//! schedule of systems, the simulation and its builder, the core
//! resources, the force-term interface and its system, recorders, the
//! sections plugins add to `summary.json`, persisted resources and the
//! simulation's errors.

pub mod core_resources;
pub mod error;
pub mod force;
pub mod frame;
pub mod frame_clock;
pub mod persisted;
pub mod recorder;
pub mod resources;
pub mod schedule;
pub mod shared_resources;
pub mod simulation;
pub mod summary_section;
pub mod term_inputs;
