//! Run outputs (SPEC §7): VTK PolyData frames (`frames/*.vtp`) with a `.pvd`
//! collection for ParaView, `series.csv` (one row per frame), `final.ply`,
//! `final.png` (side and top view) and `summary.json`.
//!
//! A run writes into `DIR.incomplete/` and renames it to `DIR` only when it
//! ends (completed or stopped by a blow-up, which `summary.json` records),
//! so a killed run never leaves a directory that looks like a result. Every
//! file is written atomically (temporary file + rename).
//!
//! Frames are written by [`FrameWriter`], an Observe-stage system, from what
//! the registered recorders produce (see [`crate::engine::recorder`]).

use crate::atomic_write;
use crate::engine::recorder::{FrameData, PointArray, Recorder};
use crate::engine::resources::{Access, CheckedResources};
use crate::engine::schedule::DynamicSystem;
use crate::engine::simulation::{Clock, DensePositions, SimError, StopRequest};
use crate::mesh::SurfaceMesh;
use crate::mesh::io::{VertexScalar, write_ply_to};
use crate::mesh::membrane::Membrane;
use std::path::{Path, PathBuf};
use vtkio::model::{
    Attribute, Attributes, ByteOrder, DataSet, IOBuffer, Piece, PolyDataPiece, Version,
    VertexNumbers, Vtk,
};

/// An output problem (names the path).
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output directory exists and may not be replaced.
    #[error("{0}: output directory already exists (choose another --out or pass --overwrite)")]
    Exists(PathBuf),
    /// A file or directory could not be written.
    #[error("{path}: cannot write: {reason}")]
    Write {
        /// The path.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

fn write_err(path: &Path, e: impl std::fmt::Display) -> OutputError {
    OutputError::Write {
        path: path.to_owned(),
        reason: e.to_string(),
    }
}

/// One written frame.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameRecord {
    /// Iteration of the frame.
    pub iteration: u64,
    /// Simulated time (s).
    pub time: f64,
    /// Path relative to the run directory.
    pub file: String,
}

/// File name of a run's checkpoint inside its staging directory
/// ([`crate::io::checkpoint`]).
pub const CHECKPOINT_FILE: &str = "checkpoint.json";

/// The outputs written so far (what a checkpoint keeps of them).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputProgress {
    /// Frames written.
    pub frames: Vec<FrameRecord>,
    /// Header of `series.csv` (after the first frame).
    pub series_header: Option<String>,
    /// Text of `series.csv` so far.
    pub series: String,
}

/// The staging directory of run directory `dir` (`dir` itself if it is
/// one already).
pub fn staging_of(dir: &Path) -> PathBuf {
    if dir.extension().is_some_and(|e| e == "incomplete") {
        return dir.to_owned();
    }
    let mut s = dir.as_os_str().to_owned();
    s.push(".incomplete");
    PathBuf::from(s)
}

/// The run directory of staging directory `staging` (`DIR.incomplete` →
/// `DIR`).
pub fn run_dir_of(staging: &Path) -> PathBuf {
    if staging.extension().is_some_and(|e| e == "incomplete") {
        staging.with_extension("")
    } else {
        staging.to_owned()
    }
}

/// The directory a run writes into.
pub struct RunOutput {
    dir: PathBuf,
    staging: PathBuf,
    /// Frames written so far.
    pub frames: Vec<FrameRecord>,
    series_header: Option<String>,
    series: String,
}

impl RunOutput {
    /// Prepares `dir` (via `dir.incomplete`). An existing `dir` is an error
    /// unless `overwrite`, in which case it is removed first.
    pub fn create(dir: &Path, overwrite: bool) -> Result<Self, OutputError> {
        let staging = prepare_staging(dir, overwrite)?;
        std::fs::create_dir_all(staging.join("frames")).map_err(|e| write_err(&staging, e))?;
        Ok(Self {
            dir: dir.to_owned(),
            staging,
            frames: Vec::new(),
            series_header: None,
            series: String::new(),
        })
    }

    /// Reopens the staging directory of `dir` to continue a run from a
    /// checkpoint: frames written after it are removed (the resumed run
    /// writes them again), so are temporary files of a killed write, and
    /// `run.pvd` and `series.csv` are set back to the checkpoint's.
    pub fn reopen(dir: &Path, progress: &OutputProgress) -> Result<Self, OutputError> {
        let staging = staging_of(dir);
        let kept: std::collections::HashSet<&str> =
            progress.frames.iter().map(|f| f.file.as_str()).collect();
        for (folder, prefix) in [(staging.join("frames"), "frames/"), (staging.clone(), "")] {
            let entries = std::fs::read_dir(&folder).map_err(|e| write_err(&folder, e))?;
            for entry in entries.flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                let stale_frame =
                    !prefix.is_empty() && !kept.contains(format!("{prefix}{name}").as_str());
                let temporary = name.starts_with('.') && name.ends_with(".tmp");
                if stale_frame || temporary {
                    std::fs::remove_file(entry.path()).map_err(|e| write_err(&entry.path(), e))?;
                }
            }
        }
        let out = Self {
            dir: run_dir_of(&staging),
            staging,
            frames: progress.frames.clone(),
            series_header: progress.series_header.clone(),
            series: progress.series.clone(),
        };
        if !out.frames.is_empty() {
            out.write("run.pvd", pvd(&out.frames).as_bytes())?;
        }
        if out.series_header.is_some() {
            out.write("series.csv", out.series.as_bytes())?;
        }
        Ok(out)
    }

    /// The outputs so far, for a checkpoint.
    pub fn progress(&self) -> OutputProgress {
        OutputProgress {
            frames: self.frames.clone(),
            series_header: self.series_header.clone(),
            series: self.series.clone(),
        }
    }

    /// Writes the checkpoint (atomically) into the staging directory.
    pub fn write_checkpoint(&self, json: &str) -> Result<(), OutputError> {
        self.write(CHECKPOINT_FILE, json.as_bytes())
    }

    /// Removes the staging directory of a run that never started.
    pub fn discard(self) {
        let _ = std::fs::remove_dir_all(&self.staging);
    }

    /// The staging directory (`DIR.incomplete`) written until the run ends.
    pub fn staging(&self) -> &Path {
        &self.staging
    }

    /// The final run directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn write(&self, relative: &str, bytes: &[u8]) -> Result<(), OutputError> {
        let path = self.staging.join(relative);
        atomic_write(&path, bytes).map_err(|e| write_err(&path, e))
    }

    /// Writes a frame `frames/frame_NNNNNN.vtp` of the mesh with the
    /// recorders' point data, adds it to the `.pvd` collection and appends
    /// the recorders' columns as a row of `series.csv` (the first frame's
    /// columns are the header).
    pub fn write_frame(
        &mut self,
        title: &str,
        positions: &[glam::DVec3],
        faces: &[[u32; 3]],
        clock: Clock,
        data: &FrameData,
    ) -> Result<(), OutputError> {
        let file = format!("frames/frame_{:06}.vtp", clock.iteration);
        let path = self.staging.join(&file);
        crate::atomic_write_with(&path, |w| {
            write_frame_vtp(w, title, positions, faces, &data.point_data)
        })
        .map_err(|e| write_err(&path, e))?;
        self.frames.push(FrameRecord {
            iteration: clock.iteration,
            time: clock.time,
            file,
        });
        self.write("run.pvd", pvd(&self.frames).as_bytes())?;
        let names: Vec<&str> = data.columns.iter().map(|(n, _)| n.as_str()).collect();
        let header = names.join(",");
        let row: Vec<&str> = data.columns.iter().map(|(_, v)| v.as_str()).collect();
        if self.series_header.is_none() {
            self.series = header.clone() + "\n";
            self.series_header = Some(header);
        }
        self.series += &row.join(",");
        self.series.push('\n');
        self.write("series.csv", self.series.as_bytes())
    }

    /// Writes the remesh events as `events.vtp` (one vertex per event, point
    /// data `split` = 1/0 and `iteration`, for ParaView) and `events.csv`.
    pub fn write_events(&self, events: &[crate::remesh::RemeshEvent]) -> Result<(), OutputError> {
        let mut csv = String::from("iteration,kind,x,y,z\n");
        for e in events {
            let kind = e.op.name();
            let [x, y, z] = e.position;
            csv += &format!("{},{kind},{x:e},{y:e},{z:e}\n", e.iteration);
        }
        self.write("events.csv", csv.as_bytes())?;
        let n = events.len() as u64;
        let vtk = Vtk {
            version: Version::new_xml(1, 0),
            title: "remesh events".to_string(),
            byte_order: ByteOrder::LittleEndian,
            file_path: None,
            data: DataSet::PolyData {
                meta: None,
                pieces: vec![Piece::Inline(Box::new(PolyDataPiece {
                    points: IOBuffer::F64(events.iter().flat_map(|e| e.position).collect()),
                    verts: Some(VertexNumbers::XML {
                        connectivity: (0..n).collect(),
                        offsets: (1..=n).collect(),
                    }),
                    lines: None,
                    polys: None,
                    strips: None,
                    data: Attributes {
                        point: vec![
                            Attribute::scalars("split", 1).with_data(
                                events
                                    .iter()
                                    .map(|e| u8::from(e.op == crate::remesh::EdgeOp::Split))
                                    .collect::<Vec<u8>>(),
                            ),
                            Attribute::scalars("iteration", 1).with_data(
                                events.iter().map(|e| e.iteration).collect::<Vec<u64>>(),
                            ),
                        ],
                        cell: Vec::new(),
                    },
                }))],
            },
        };
        let mut out = Vec::new();
        write_vtk_xml(vtk, &mut out).map_err(|e| write_err(&self.staging.join("events.vtp"), e))?;
        self.write("events.vtp", &out)
    }

    /// Writes `final.ply`, `final.png`, `state.json` (if given) and
    /// `summary.json`, then moves the run into place.
    pub fn finish(
        self,
        summary_json: &str,
        final_mesh: &SurfaceMesh,
        lipid: &[f64],
        state_json: Option<&str>,
    ) -> Result<PathBuf, OutputError> {
        let mut ply = Vec::new();
        let scalars: Vec<VertexScalar<'_>> = if lipid.is_empty() {
            Vec::new()
        } else {
            vec![VertexScalar {
                name: "density",
                values: lipid,
            }]
        };
        write_ply_to(
            &mut ply,
            final_mesh,
            &scalars,
            "final state written by remembrane",
        )
        .map_err(|e| write_err(&self.staging.join("final.ply"), e))?;
        self.write("final.ply", &ply)?;
        let png = crate::io::render::render_png(&final_mesh.positions, &final_mesh.faces, 400);
        self.write("final.png", &png)?;
        if let Some(state) = state_json {
            self.write("state.json", state.as_bytes())?;
        }
        self.write("summary.json", summary_json.as_bytes())?;
        // A finished run is not resumed: its checkpoint goes.
        let checkpoint = self.staging.join(CHECKPOINT_FILE);
        if checkpoint.exists() {
            std::fs::remove_file(&checkpoint).map_err(|e| write_err(&checkpoint, e))?;
        }
        std::fs::rename(&self.staging, &self.dir).map_err(|e| write_err(&self.dir, e))?;
        Ok(self.dir)
    }
}

/// Prepares the staging directory `dir.incomplete` of an output that is
/// renamed to `dir` when it is complete: an existing `dir` is an error
/// unless `overwrite` (then it is removed), a stale staging directory is
/// removed, and the staging directory is created empty.
pub fn prepare_staging(dir: &Path, overwrite: bool) -> Result<PathBuf, OutputError> {
    if dir.exists() {
        if !overwrite {
            return Err(OutputError::Exists(dir.to_owned()));
        }
        std::fs::remove_dir_all(dir).map_err(|e| write_err(dir, e))?;
    }
    let mut staging = dir.as_os_str().to_owned();
    staging.push(".incomplete");
    let staging = PathBuf::from(staging);
    if staging.exists() {
        std::fs::remove_dir_all(&staging).map_err(|e| write_err(&staging, e))?;
    }
    std::fs::create_dir_all(&staging).map_err(|e| write_err(&staging, e))?;
    Ok(staging)
}

/// Writes a VTK XML PolyData document of a triangle mesh with point data
/// to `writer`.
pub fn write_frame_vtp(
    writer: impl std::io::Write,
    title: &str,
    positions: &[glam::DVec3],
    faces: &[[u32; 3]],
    point_data: &[PointArray],
) -> Result<(), vtkio::Error> {
    let points: Vec<f64> = positions.iter().flat_map(|p| p.to_array()).collect();
    let connectivity: Vec<u64> = faces.iter().flat_map(|f| f.map(u64::from)).collect();
    let offsets: Vec<u64> = (1..=faces.len() as u64).map(|i| 3 * i).collect();
    let point = point_data
        .iter()
        .map(|a| match a {
            PointArray::Vectors { name, values } => Attribute::vectors(name.as_str()).with_data(
                values
                    .iter()
                    .flat_map(|f| f.to_array())
                    .collect::<Vec<f64>>(),
            ),
            PointArray::Scalars { name, values } => {
                Attribute::scalars(name.as_str(), 1).with_data(values.clone())
            }
        })
        .collect();
    let vtk = Vtk {
        version: Version::new_xml(1, 0),
        title: title.to_string(),
        byte_order: ByteOrder::LittleEndian,
        file_path: None,
        data: DataSet::PolyData {
            meta: None,
            pieces: vec![Piece::Inline(Box::new(PolyDataPiece {
                points: IOBuffer::F64(points),
                verts: None,
                lines: None,
                polys: Some(VertexNumbers::XML {
                    connectivity,
                    offsets,
                }),
                strips: None,
                data: Attributes {
                    point,
                    cell: Vec::new(),
                },
            }))],
        },
    };
    write_vtk_xml(vtk, writer)
}

/// Writes `vtk` as VTK XML to `writer` through [`WriteAll`], so that every
/// byte vtkio hands over is written: vtkio 0.7's XML writer bridges its
/// `fmt::Write` serializer to the sink with `write` (not `write_all`) and
/// ignores the count it returns, so a sink that takes part of a buffer would
/// lose the rest silently (and vtkio's serializer, quick-xml, passes the
/// document in a few large pieces, which go past vtkio's `BufWriter`
/// straight to the sink). vtkio also flushes its `BufWriter` into the sink
/// when it drops it, where an error would be lost: `WriteAll` keeps the
/// first error, which is returned.
fn write_vtk_xml(vtk: Vtk, writer: impl std::io::Write) -> Result<(), vtkio::Error> {
    use std::io::Write;
    let mut sink = WriteAll {
        inner: writer,
        error: None,
    };
    let written = vtk.write_xml(&mut sink);
    if let Some(e) = sink.error.take() {
        return Err(vtkio::Error::IO(e));
    }
    written?;
    sink.flush()?;
    Ok(())
}

/// An `io::Write` whose `write` writes the whole buffer (`write_all`) or
/// fails; after its first error (kept in `error`) every write fails.
struct WriteAll<W> {
    inner: W,
    error: Option<std::io::Error>,
}

impl<W: std::io::Write> std::io::Write for WriteAll<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.error.is_some() {
            return Err(std::io::Error::other("an earlier write failed"));
        }
        match self.inner.write_all(buf) {
            Ok(()) => Ok(buf.len()),
            Err(e) => {
                let returned = std::io::Error::new(e.kind(), e.to_string());
                self.error = Some(e);
                Err(returned)
            }
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if self.error.is_some() {
            return Err(std::io::Error::other("an earlier write failed"));
        }
        self.inner.flush()
    }
}

/// A ParaView `.pvd` collection of the frames (time = simulated time).
fn pvd(frames: &[FrameRecord]) -> String {
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n",
    );
    for f in frames {
        s += &format!(
            "    <DataSet timestep=\"{:e}\" group=\"\" part=\"0\" file=\"{}\"/>\n",
            f.time, f.file
        );
    }
    s += "  </Collection>\n</VTKFile>\n";
    s
}

/// When frames are due: every `interval` iterations, or each time the
/// simulated time crosses a multiple of `frame_time`, plus the first and the
/// last state of the run.
#[derive(Clone, Debug)]
pub struct FrameSchedule {
    interval: u64,
    frame_time: Option<f64>,
    next_frame_time: f64,
    iterations: u64,
    duration: f64,
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
    title: String,
    schedule: FrameSchedule,
    recorders: Vec<Box<dyn Recorder>>,
    access: Access,
    /// The iteration of the last frame written (a run that stops early
    /// writes its final state once, even when a frame was due at it).
    last_written: Option<u64>,
}

/// Name of the frame-writing system.
pub const FRAMES: &str = "frames";

impl FrameWriter {
    /// A writer of frames titled `title`, due by `schedule`, with
    /// `recorders` (in order).
    pub fn new(title: &str, schedule: FrameSchedule, recorders: Vec<Box<dyn Recorder>>) -> Self {
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
            title: title.to_string(),
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
struct FrameWriterState {
    next_frame_time: Option<f64>,
    recorders: Option<serde_json::Value>,
}

fn recorder_key(index: usize, recorder: &dyn Recorder) -> String {
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
            &self.title,
            &positions.0,
            &membrane.cached_topology().faces,
            clock,
            &data,
        )
        .map_err(|e| SimError::Output(e.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// A sink that takes at most `max` bytes per `write` call (a legal
    /// short write), like a pipe, a socket or a file on a full disk.
    struct Trickle {
        bytes: Vec<u8>,
        max: usize,
        calls: usize,
    }

    impl Write for Trickle {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.calls += 1;
            let n = buf.len().min(self.max);
            self.bytes.extend_from_slice(&buf[..n]);
            Ok(n)
        }

        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A sink that fails after `budget` bytes.
    struct Failing {
        budget: usize,
    }

    impl Write for Failing {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            if self.budget == 0 {
                return Err(std::io::Error::other("disk full"));
            }
            let n = buf.len().min(self.budget);
            self.budget -= n;
            Ok(n)
        }

        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A frame of a 2562-vertex sphere, about 200 kB: far more than vtkio's
    /// 8 KiB buffer, so vtkio hands it to the sink in a few large `write`
    /// calls (quick-xml builds each element's content in memory first).
    fn frame(writer: impl Write) -> Result<(), vtkio::Error> {
        let mesh = crate::mesh::icosphere_unit(4);
        let n = mesh.positions.len();
        let point_data = vec![
            PointArray::Vectors {
                name: "force".into(),
                values: mesh.positions.iter().map(|p| -2.0 * *p).collect(),
            },
            PointArray::Scalars {
                name: "mean_curvature".into(),
                values: (0..n).map(|i| i as f64 / n as f64).collect(),
            },
        ];
        write_frame_vtp(writer, "trickle", &mesh.positions, &mesh.faces, &point_data)
    }

    #[test]
    fn a_frame_is_written_whole_through_a_sink_that_takes_a_few_bytes_per_write() {
        let mut whole = Vec::new();
        frame(&mut whole).unwrap();
        let mut trickle = Trickle {
            bytes: Vec::new(),
            max: 3,
            calls: 0,
        };
        frame(&mut trickle).unwrap();
        assert!(whole.len() > 100_000, "{} bytes", whole.len());
        assert!(whole.ends_with(b"</VTKFile>"));
        assert!(
            trickle.bytes == whole,
            "the trickled file differs: {} bytes, {} expected",
            trickle.bytes.len(),
            whole.len()
        );
        assert!(trickle.calls >= whole.len() / 3, "{} calls", trickle.calls);
        // And it is a complete VTK file: it parses back, every point there.
        let vtk = vtkio::Vtk::parse_xml(trickle.bytes.as_slice()).unwrap();
        let DataSet::PolyData { pieces, .. } = vtk.data else {
            panic!("not PolyData")
        };
        let piece = pieces[0].load_piece_data(None).unwrap();
        let points: Vec<f64> = piece.points.cast_into().unwrap();
        let mesh = crate::mesh::icosphere_unit(4);
        let expected: Vec<f64> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
        assert_eq!(points, expected);
        assert_eq!(piece.data.point.len(), 2);
    }

    #[test]
    fn a_failing_sink_is_an_error() {
        for budget in [0, 10, 9_000, 60_000] {
            let err = frame(Failing { budget }).unwrap_err();
            assert!(err.to_string().contains("disk full"), "{budget}: {err}");
        }
    }
}
