//! What goes to and from disk: run directories, their summary and its
//! typed reader, frames (VTK), state files, checkpoints and world
//! snapshots, the energy report, PNG renders and plots, and a run's
//! flicker spectrum.

pub mod checkpoint;
pub mod output;
pub mod plot;
pub mod recorders;
pub mod render;
pub mod report;
pub mod run_dir;
pub mod spectrum;
pub mod state;
pub mod summary;
pub mod world_snapshot;
