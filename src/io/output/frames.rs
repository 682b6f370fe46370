//! The Output-stage system that writes each frame the recorders filled,
//! and the plugin that adds it.

use super::*;
use crate::engine::resources::{Res, ResMut};
use crate::engine::schedule::{Stage, System};
use crate::engine::simulation::{BuildError, Clock, CurrentFrame, DensePositions, SimBuilder};

pub use crate::engine::frame_clock::FrameSchedule;

/// The run's output directory, once a run opened one. `None` (as built): a
/// simulation stepped without a run, whose frames are not written. A run
/// opens it before its first tick ([`RunOutput::create`] or, resuming,
/// [`RunOutput::reopen`]) and takes it back at the end.
#[derive(Default)]
pub struct OpenOutput(pub Option<RunOutput>);

impl OpenOutput {
    /// The open output directory, if any.
    pub fn get(&self) -> Option<&RunOutput> {
        self.0.as_ref()
    }
}

/// Name of the frame-writing system.
pub const FRAMES: &str = "frames";

/// The run's frame writer: when the Observe stage recorded a frame, writes
/// it (VTK frame and `series.csv` row) into the open output directory.
///
/// Stage: Output. Reads: [`CurrentFrame`], [`Clock`], [`Membrane`],
/// [`DensePositions`]. Writes: [`OpenOutput`].
pub struct FrameWriter;

impl System for FrameWriter {
    type Data<'a> = (
        Res<'a, CurrentFrame>,
        Res<'a, Clock>,
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        ResMut<'a, OpenOutput>,
    );

    fn name(&self) -> &str {
        FRAMES
    }

    fn run(
        &mut self,
        (frame, clock, membrane, positions, mut out): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let Some(out) = out.0.as_mut().filter(|_| frame.due) else {
            return Ok(());
        };
        out.write_frame(
            &positions.0,
            &membrane.cached_topology().faces,
            *clock,
            &frame.data,
        )
        .map_err(|e| SimError::Output(e.to_string()))
    }
}

/// Frame output: the frame clock (recorders fill the frames it opens), an
/// empty [`OpenOutput`] and the [`FrameWriter`]. A run sets the
/// [`FrameSchedule`] and opens the output before its first tick.
pub fn frame_output(builder: &mut SimBuilder) -> Result<(), BuildError> {
    builder.add_frame_clock();
    builder.insert_resource(OpenOutput::default());
    builder.add_system(Stage::Output, FrameWriter);
    Ok(())
}
