//! Recorders: what a frame contains. A recorder is a typed Observe-stage
//! system: its [`Recorder::Data`] declares what it reads, exactly as a
//! [`System`]'s does, so its access is derived from its type and checked
//! when the schedule is built. When a frame is due
//! ([`CurrentFrame::due`], set by the `frame_clock` system,
//! [`crate::engine::frame_clock`]) it adds series columns and per-vertex
//! point data to the [`CurrentFrame`]; the run's frame writer (Output
//! stage) writes the VTK frame and the `series.csv` row from them. A plugin
//! adds a column or a point-data array by registering a recorder
//! ([`crate::engine::simulation::SimBuilder::add_recorder`]), without
//! touching the output code.
//!
//! The Observe stage runs right after the Forces stage: it sees the state
//! of the last completed iteration together with the forces the next step
//! will apply, so frames reuse the tick's forces instead of evaluating them
//! again.

use crate::engine::error::SimError;
pub use crate::engine::frame::{CurrentFrame, FrameData, PointArray};
use crate::engine::resources::{ResMut, SystemData};
use crate::engine::schedule::System;

/// Adds columns and point data to frames.
///
/// ```
/// use remembrane_core::engine::recorder::{FrameData, Recorder};
/// use remembrane_core::engine::resources::Res;
/// use remembrane_core::engine::simulation::{DensePositions, SimError};
///
/// /// The highest vertex, as a series column.
/// struct Top;
///
/// impl Recorder for Top {
///     type Data<'a> = Res<'a, DensePositions>;
///     fn name(&self) -> &str {
///         "top"
///     }
///     fn record(&mut self, p: Self::Data<'_>, frame: &mut FrameData) -> Result<(), SimError> {
///         frame.column("top", p.0.iter().map(|x| x.z).fold(f64::MIN, f64::max));
///         Ok(())
///     }
/// }
/// ```
pub trait Recorder: Send + 'static {
    /// The resources it reads, declared by type as a [`System`]'s are.
    type Data<'a>: SystemData<'a>;
    /// Name; its system in the schedule is `record_<name>`.
    fn name(&self) -> &str;
    /// Records the observed state into `frame` (called only when a frame
    /// is due).
    fn record(&mut self, data: Self::Data<'_>, frame: &mut FrameData) -> Result<(), SimError>;
    /// State the recorder carries from one frame to the next (e.g. a first
    /// frame's value that later frames are divided by), for checkpoints;
    /// `None` (the default) means none.
    fn save_state(&self) -> Option<serde_json::Value> {
        None
    }
    /// Takes back what `save_state` returned (on resuming a run).
    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError> {
        let _ = state;
        Err(crate::engine::error::StateError::Stateless)
    }
}

/// The Observe-stage system that runs a [`Recorder`] when a frame is due.
///
/// Stage: Observe, after `frame_clock`. Reads: what the recorder declares.
/// Writes: [`CurrentFrame`].
pub(crate) struct RecorderSystem<R> {
    recorder: R,
    name: String,
}

impl<R: Recorder> RecorderSystem<R> {
    pub(crate) fn new(recorder: R) -> Self {
        let name = format!("record_{}", recorder.name());
        Self { recorder, name }
    }
}

impl<R: Recorder> System for RecorderSystem<R> {
    type Data<'a> = (ResMut<'a, CurrentFrame>, R::Data<'a>);

    fn name(&self) -> &str {
        &self.name
    }

    fn run(&mut self, (mut frame, data): Self::Data<'_>) -> Result<(), SimError> {
        if !frame.due {
            return Ok(());
        }
        self.recorder.record(data, &mut frame.data)
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        self.recorder.save_state()
    }

    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError> {
        self.recorder.restore_state(state)
    }
}
