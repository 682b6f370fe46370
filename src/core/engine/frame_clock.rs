//! When frames are due, and the Observe-stage system that opens each due
//! frame for the recorders ([`crate::engine::recorder`]).
//!
//! A simulation built with recorders has the [`FrameSchedule`] resource
//! (by default no frame is ever due) and the [`CurrentFrame`] the
//! recorders fill. A run sets the schedule before its first tick; the run's
//! frame writer (Output stage) writes the frame that the recorders filled.

use crate::engine::core_resources::{Clock, StopRequest};
use crate::engine::error::SimError;
pub use crate::engine::frame::CurrentFrame;
use crate::engine::resources::{Res, ResMut};
use crate::engine::schedule::System;

/// Name of the frame-opening system (recorders run after it).
pub const FRAME_CLOCK: &str = "frame_clock";

/// When frames are due: every `interval` iterations, or each time the
/// simulated time crosses a multiple of `frame_time`, plus the first and the
/// last state of the run. A run's checkpoints keep it (the next frame time
/// of a `frame_time` schedule is state).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameSchedule {
    interval: u64,
    /// Simulated time between frames (s), for a schedule by time.
    frame_time: Option<f64>,
    /// The next frame time (s) of a schedule by time.
    next_frame_time: Option<f64>,
    iterations: u64,
    /// The run's duration (s); `None`: no limit.
    duration: Option<f64>,
    /// The iteration of the last frame opened (a run that stops early
    /// records its final state once, even when a frame was due at it).
    #[serde(skip)]
    last_opened: Option<u64>,
    /// Whether any frame is due at all (`false`: a simulation stepped
    /// without a run, whose recorders never run).
    active: bool,
}

impl FrameSchedule {
    /// Frames for a run of `iterations` (and at most `duration` s): `frames`
    /// evenly spaced, or one per `frame_time` of simulated time if given.
    pub fn new(iterations: u64, frames: u32, frame_time: Option<f64>, duration: f64) -> Self {
        let interval = if frames == 0 {
            u64::MAX
        } else {
            iterations.div_ceil(frames as u64).max(1)
        };
        Self {
            interval,
            frame_time,
            next_frame_time: frame_time,
            iterations,
            duration: duration.is_finite().then_some(duration),
            last_opened: None,
            active: true,
        }
    }

    /// No frame is ever due (a simulation stepped without a run).
    pub fn never() -> Self {
        Self {
            active: false,
            ..Self::new(0, 0, None, f64::INFINITY)
        }
    }

    /// The next frame time of a `frame_time` schedule (s); `None` for a
    /// schedule by iterations.
    pub fn next_frame_time(&self) -> Option<f64> {
        self.next_frame_time
    }

    /// Whether the state after `iteration` iterations at `time` gets a frame.
    pub fn due(&mut self, iteration: u64, time: f64) -> bool {
        if !self.active {
            return false;
        }
        if iteration == 0 {
            return true;
        }
        let last = iteration >= self.iterations || self.duration.is_some_and(|d| time >= d);
        let due = match (self.frame_time, self.next_frame_time.as_mut()) {
            (Some(step), Some(next)) if time >= *next => {
                while *next <= time {
                    *next += step;
                }
                true
            }
            (Some(_), _) => false,
            (None, _) => iteration.is_multiple_of(self.interval),
        };
        due || last
    }

    /// Whether the state after `iteration` iterations at `time` gets a
    /// frame, given whether a system asked the run to stop: a stopping run
    /// records its state once.
    fn opens(&mut self, iteration: u64, time: f64, stopping: bool) -> bool {
        let due = self.due(iteration, time);
        let open =
            self.active && (due || stopping) && !(stopping && self.last_opened == Some(iteration));
        if open {
            self.last_opened = Some(iteration);
        }
        open
    }
}

/// Opens a frame when one is due: sets [`CurrentFrame::due`] and empties it.
///
/// Stage: Observe, before every recorder. Reads: [`Clock`], [`StopRequest`]
/// (optional: a run asked to stop records its final state). Writes:
/// [`FrameSchedule`], [`CurrentFrame`].
pub(crate) struct FrameClock;

impl System for FrameClock {
    type Data<'a> = (
        Res<'a, Clock>,
        Option<Res<'a, StopRequest>>,
        ResMut<'a, FrameSchedule>,
        ResMut<'a, CurrentFrame>,
    );

    fn name(&self) -> &str {
        FRAME_CLOCK
    }

    fn run(
        &mut self,
        (clock, stop, mut schedule, mut frame): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let stopping = stop.is_some_and(|r| r.0.is_some());
        frame.due = schedule.opens(clock.iteration, clock.time, stopping);
        frame.data.clear();
        Ok(())
    }
}
