//! Recorders: what a frame contains. Each recorder reads the observed state
//! (the resources it declares) and adds series columns and per-vertex point
//! data to a [`FrameData`]. The run's frame writer, an Observe-stage system,
//! calls every recorder when a frame is due and writes the VTK frame and the
//! `series.csv` row from what they produced, so a plugin adds a column or a
//! point-data array by registering a recorder
//! ([`crate::engine::simulation::SimBuilder::add_recorder`]), without touching the
//! output code.
//!
//! The Observe stage runs right after the Forces stage: it sees the state
//! of the last completed iteration together with the forces the next step
//! will apply, so frames reuse the tick's forces instead of evaluating them
//! again.

use crate::engine::error::SimError;
use crate::engine::resources::{Access, CheckedResources};
use glam::DVec3;

/// One per-vertex array of a frame (by dense vertex slot).
#[derive(Clone, Debug, PartialEq)]
pub enum PointArray {
    /// One value per vertex.
    Scalars {
        /// Array name in the VTK file.
        name: String,
        /// Values.
        values: Vec<f64>,
    },
    /// A 3-vector per vertex.
    Vectors {
        /// Array name in the VTK file.
        name: String,
        /// Values.
        values: Vec<DVec3>,
    },
}

/// What the recorders produced for one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameData {
    /// Series columns: (header name, formatted value), in recorder order.
    pub columns: Vec<(String, String)>,
    /// Point-data arrays, in recorder order.
    pub point_data: Vec<PointArray>,
}

impl FrameData {
    /// Adds a floating-point column (written as `{:e}`).
    pub fn column(&mut self, name: impl Into<String>, value: f64) {
        self.columns.push((name.into(), format!("{value:e}")));
    }

    /// Adds an integer column.
    pub fn count(&mut self, name: impl Into<String>, value: u64) {
        self.columns.push((name.into(), value.to_string()));
    }

    /// Adds a per-vertex scalar array.
    pub fn scalars(&mut self, name: impl Into<String>, values: Vec<f64>) {
        self.point_data.push(PointArray::Scalars {
            name: name.into(),
            values,
        });
    }

    /// Adds a per-vertex vector array.
    pub fn vectors(&mut self, name: impl Into<String>, values: Vec<DVec3>) {
        self.point_data.push(PointArray::Vectors {
            name: name.into(),
            values,
        });
    }
}

/// Adds columns and point data to frames.
pub trait Recorder: Send + 'static {
    /// Name (for errors).
    fn name(&self) -> &str;
    /// The resources it reads (a read of anything else fails the frame).
    fn access(&self) -> Access;
    /// Records the observed state into `frame`.
    fn record(
        &mut self,
        state: &CheckedResources<'_>,
        frame: &mut FrameData,
    ) -> Result<(), SimError>;
    /// State the recorder carries from one frame to the next (e.g. a first
    /// frame's value that later frames are divided by), for checkpoints;
    /// `None` (the default) means none.
    fn save_state(&self) -> Option<serde_json::Value> {
        None
    }
    /// Takes back what `save_state` returned (on resuming a run).
    fn restore_state(&mut self, state: serde_json::Value) -> Result<(), String> {
        let _ = state;
        Err("this recorder keeps no state".into())
    }
}

/// The recorders registered so far, in order; the run's frame writer takes
/// them when it is added.
#[derive(Default)]
pub struct Recorders(pub Vec<Box<dyn Recorder>>);

/// A recorder's read failed: the error names the recorder.
pub fn read_error(
    recorder: &str,
) -> impl Fn(crate::engine::resources::FetchError) -> SimError + '_ {
    move |source| SimError::Resource {
        system: format!("recorder `{recorder}`"),
        source,
    }
}
