//! What goes to and from disk: run directories and their typed reader,
//! frames (VTK), state files, checkpoints and world snapshots, the energy
//! report, PNG renders and plots.

pub mod checkpoint;
pub mod output;
pub mod plot;
pub mod recorders;
pub mod render;
pub mod report;
pub mod run_dir;
pub mod state;
pub mod world_snapshot;
