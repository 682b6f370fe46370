//! When frames are due, and the Observe-stage system that writes them
//! with the recorders' arrays.

use super::*;

/// When frames are due: every `interval` iterations, or each time the
/// simulated time crosses a multiple of `frame_time`, plus the first and the
/// last state of the run.
#[derive(Clone, Debug)]
pub struct FrameSchedule {
    pub(super) interval: u64,
    pub(super) frame_time: Option<f64>,
    pub(super) next_frame_time: f64,
    pub(super) iterations: u64,
    pub(super) duration: f64,
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
            next_frame_time: frame_time.unwrap_or(f64::INFINITY),
            iterations,
            duration,
        }
    }

    /// The next frame time of a `frame_time` schedule (s); `None` for a
    /// schedule by iterations. What a checkpoint keeps.
    pub fn next_frame_time(&self) -> Option<f64> {
        self.frame_time.map(|_| self.next_frame_time)
    }

    /// Continues a schedule at `next` (from [`FrameSchedule::next_frame_time`]).
    pub fn resume_at(&mut self, next: Option<f64>) {
        if let (Some(_), Some(next)) = (self.frame_time, next) {
            self.next_frame_time = next;
        }
    }

    /// Whether the state after `iteration` iterations at `time` gets a frame.
    pub fn due(&mut self, iteration: u64, time: f64) -> bool {
        if iteration == 0 {
            return true;
        }
        let last = iteration >= self.iterations || time >= self.duration;
        let due = match self.frame_time {
            Some(step) if time >= self.next_frame_time => {
                while self.next_frame_time <= time {
                    self.next_frame_time += step;
                }
                true
            }
            Some(_) => false,
            None => iteration.is_multiple_of(self.interval),
        };
        due || last
    }
}

/// The run's frame writer: in the Observe stage, when a frame is due, calls
/// every recorder and writes the frame and its series row into the
/// [`RunOutput`] resource.
///
/// Stage: Observe. Reads: [`Clock`], [`Membrane`], [`DensePositions`],
/// [`StopRequest`] (a run asked to stop writes its final state) and
/// whatever the recorders declare. Writes: [`RunOutput`].
pub struct FrameWriter {
    pub(super) schedule: FrameSchedule,
    pub(super) recorders: Vec<Box<dyn Recorder>>,
    pub(super) access: Access,
    /// The iteration of the last frame written (a run that stops early
    /// writes its final state once, even when a frame was due at it).
    pub(super) last_written: Option<u64>,
}

/// Name of the frame-writing system.
pub const FRAMES: &str = "frames";

impl FrameWriter {
    /// A writer of frames due by `schedule`, with `recorders` (in order).
    pub fn new(schedule: FrameSchedule, recorders: Vec<Box<dyn Recorder>>) -> Self {
        let mut access = Access::default()
            .read::<Clock>()
            .read::<Membrane>()
            .read::<DensePositions>()
            .read_optional::<StopRequest>()
            .write::<RunOutput>();
        for r in &recorders {
            access.merge(&r.access());
        }
        Self {
            schedule,
            recorders,
            access,
            last_written: None,
        }
    }
}

/// What a checkpoint keeps of the frame writer.
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FrameWriterState {
    pub(super) next_frame_time: Option<f64>,
    pub(super) recorders: Option<serde_json::Value>,
}

pub(super) fn recorder_key(index: usize, recorder: &dyn Recorder) -> String {
    format!("{index}:{}", recorder.name())
}

impl DynamicSystem for FrameWriter {
    fn name(&self) -> &str {
        FRAMES
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        let state = FrameWriterState {
            next_frame_time: self.schedule.next_frame_time(),
            recorders: crate::engine::persisted::save_named(
                self.recorders
                    .iter()
                    .enumerate()
                    .map(|(i, r)| (recorder_key(i, r.as_ref()), r.save_state())),
            ),
        };
        serde_json::to_value(state).ok()
    }

    fn restore_state(&mut self, state: serde_json::Value) -> Result<(), String> {
        let state: FrameWriterState = serde_json::from_value(state).map_err(|e| e.to_string())?;
        self.schedule.resume_at(state.next_frame_time);
        if let Some(recorders) = state.recorders {
            crate::engine::persisted::restore_named(
                &mut self.recorders,
                |i, r| recorder_key(i, r.as_ref()),
                |r, v| r.restore_state(v),
                recorders,
            )
            .map_err(|e| format!("recorder {e}"))?;
        }
        Ok(())
    }

    fn access(&self) -> Access {
        self.access.clone()
    }

    fn run(&mut self, s: &CheckedResources<'_>) -> Result<(), SimError> {
        let err = |source| SimError::Resource {
            system: FRAMES.into(),
            source,
        };
        let clock = *s.get::<Clock>().map_err(err)?;
        // A run that a system asked to stop (a converged minimisation)
        // ends here: its state gets a frame, once.
        let stopping = s.get::<StopRequest>().is_ok_and(|r| r.0.is_some());
        let due = self.schedule.due(clock.iteration, clock.time);
        if stopping && self.last_written == Some(clock.iteration) || !(due || stopping) {
            return Ok(());
        }
        self.last_written = Some(clock.iteration);
        let mut data = FrameData::default();
        for r in &mut self.recorders {
            r.record(s, &mut data)?;
        }
        let membrane = s.get::<Membrane>().map_err(err)?;
        let positions = s.get::<DensePositions>().map_err(err)?;
        let mut out = s.get_mut::<RunOutput>().map_err(err)?;
        out.write_frame(
            &positions.0,
            &membrane.cached_topology().faces,
            clock,
            &data,
        )
        .map_err(|e| SimError::Output(e.to_string()))
    }
}
