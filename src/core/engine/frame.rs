//! What one frame holds: the series columns and per-vertex arrays that
//! the recorders ([`crate::engine::recorder`]) produce, and the frame of
//! the current tick that they fill when the frame clock
//! ([`crate::engine::frame_clock`]) opened one.

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

    /// Empties the frame (kept allocations).
    pub fn clear(&mut self) {
        self.columns.clear();
        self.point_data.clear();
    }
}

/// The frame of this tick: whether it is due, and what the recorders put in
/// it so far.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CurrentFrame {
    /// Whether this tick's Observe stage records a frame.
    pub due: bool,
    /// The columns and point data recorded so far.
    pub data: FrameData,
}
