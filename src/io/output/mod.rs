//! Run outputs (SPEC §7): VTK PolyData frames (`frames/*.vtp`) with a `.pvd`
//! collection for ParaView, `series.csv` (one row per frame), `final.ply`,
//! `final.png` (side and top view, coloured by the first protein species' φ) and `summary.json`.
//!
//! A run writes into `DIR.incomplete/` and renames it to `DIR` only when it
//! ends (completed or stopped by a blow-up, which `summary.json` records),
//! so a killed run never leaves a directory that looks like a result. Every
//! file is written atomically (temporary file + rename).
//!
//! Frames are written by [`FrameWriter`], an Observe-stage system, from what
//! the registered recorders produce (see [`crate::engine::recorder`]).

use crate::atomic_write;
use crate::engine::recorder::{FrameData, PointArray};
use crate::engine::simulation::{Clock, SimError};
use crate::mesh::SurfaceMesh;
use crate::mesh::io::{VertexScalar, write_ply_to};
use crate::mesh::membrane::Membrane;
use std::path::{Path, PathBuf};

mod frames;
pub mod vtk_xml;
mod vtp;

pub use frames::*;
use vtk_xml::{Cells, DataArray, Values, write_poly_data};
pub use vtp::*;

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
        positions: &[glam::DVec3],
        faces: &[[u32; 3]],
        clock: Clock,
        data: &FrameData,
    ) -> Result<(), OutputError> {
        let file = format!("frames/frame_{:06}.vtp", clock.iteration);
        let path = self.staging.join(&file);
        crate::atomic_write_with(&path, |w| {
            write_frame_vtp(w, positions, faces, &data.point_data)
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
        let points: Vec<glam::DVec3> = events.iter().map(|e| e.position.into()).collect();
        let split: Vec<u8> = events
            .iter()
            .map(|e| u8::from(e.op == crate::remesh::EdgeOp::Split))
            .collect();
        let iteration: Vec<u64> = events.iter().map(|e| e.iteration).collect();
        let arrays = [
            DataArray {
                name: "split",
                values: Values::U8(&split),
            },
            DataArray {
                name: "iteration",
                values: Values::U64(&iteration),
            },
        ];
        let mut out = Vec::new();
        write_poly_data(&mut out, &points, Cells::PointVertices, &arrays)
            .map_err(|e| write_err(&self.staging.join("events.vtp"), e))?;
        self.write("events.vtp", &out)
    }

    /// Writes `final.ply` (with the lipid density as `density` and the
    /// per-vertex `fields`, each a name and its values), `final.png`,
    /// `state.json` (if given) and `summary.json`, then moves the run into
    /// place.
    pub fn finish(
        self,
        summary_json: &str,
        final_mesh: &SurfaceMesh,
        lipid: &[f64],
        fields: &[(String, Vec<f64>)],
        state_json: Option<&str>,
    ) -> Result<PathBuf, OutputError> {
        let mut ply = Vec::new();
        let mut scalars: Vec<VertexScalar<'_>> = Vec::new();
        if !lipid.is_empty() {
            scalars.push(VertexScalar {
                name: "density",
                values: lipid,
            });
        }
        scalars.extend(
            fields
                .iter()
                .map(|(name, values)| VertexScalar { name, values }),
        );
        write_ply_to(
            &mut ply,
            final_mesh,
            &scalars,
            "final state written by remembrane",
        )
        .map_err(|e| write_err(&self.staging.join("final.ply"), e))?;
        self.write("final.ply", &ply)?;
        // Coloured by the first protein species' fraction, if any.
        let phi = fields
            .iter()
            .find(|(name, _)| name.starts_with("phi_"))
            .map(|(_, values)| &values[..]);
        let png = crate::io::render::render_png_coloured(
            &final_mesh.positions,
            &final_mesh.faces,
            phi,
            400,
        );
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

    /// The point data of a frame of `mesh`: a force and a curvature.
    fn frame_data(mesh: &SurfaceMesh) -> Vec<PointArray> {
        let n = mesh.positions.len();
        vec![
            PointArray::Vectors {
                name: "force".into(),
                values: mesh.positions.iter().map(|p| -2.0 * *p).collect(),
            },
            PointArray::Scalars {
                name: "mean_curvature".into(),
                values: (0..n).map(|i| i as f64 / n as f64).collect(),
            },
        ]
    }

    /// A frame of a 2562-vertex sphere, about 200 kB.
    fn frame(writer: impl Write) -> std::io::Result<()> {
        let mesh = crate::mesh::icosphere_unit(4);
        write_frame_vtp(writer, &mesh.positions, &mesh.faces, &frame_data(&mesh))
    }

    /// The same frame as vtkio 0.7 writes it from its whole-document model
    /// (what the frames were before the streaming writer).
    fn vtkio_frame(mesh: &SurfaceMesh, point_data: &[PointArray]) -> Vec<u8> {
        use vtkio::model::*;
        let point = point_data
            .iter()
            .map(|a| match a {
                PointArray::Vectors { name, values } => Attribute::vectors(name.as_str())
                    .with_data(
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
        let faces = &mesh.faces;
        let vtk = Vtk {
            version: Version::new_xml(1, 0),
            title: String::new(),
            byte_order: ByteOrder::LittleEndian,
            file_path: None,
            data: DataSet::PolyData {
                meta: None,
                pieces: vec![Piece::Inline(Box::new(PolyDataPiece {
                    points: IOBuffer::F64(
                        mesh.positions.iter().flat_map(|p| p.to_array()).collect(),
                    ),
                    polys: Some(VertexNumbers::XML {
                        connectivity: faces.iter().flat_map(|f| f.map(u64::from)).collect(),
                        offsets: (1..=faces.len() as u64).map(|i| 3 * i).collect(),
                    }),
                    data: Attributes {
                        point,
                        cell: Vec::new(),
                    },
                    ..Default::default()
                }))],
            },
        };
        let mut out = Vec::new();
        vtk.write_xml(&mut out).unwrap();
        out
    }

    /// Remesh events as vtkio 0.7 writes them.
    fn vtkio_events(points: &[glam::DVec3], split: &[u8], iteration: &[u64]) -> Vec<u8> {
        use vtkio::model::*;
        let n = points.len() as u64;
        let vtk = Vtk {
            version: Version::new_xml(1, 0),
            title: String::new(),
            byte_order: ByteOrder::LittleEndian,
            file_path: None,
            data: DataSet::PolyData {
                meta: None,
                pieces: vec![Piece::Inline(Box::new(PolyDataPiece {
                    points: IOBuffer::F64(points.iter().flat_map(|p| p.to_array()).collect()),
                    verts: Some(VertexNumbers::XML {
                        connectivity: (0..n).collect(),
                        offsets: (1..=n).collect(),
                    }),
                    data: Attributes {
                        point: vec![
                            Attribute::scalars("split", 1).with_data(split.to_vec()),
                            Attribute::scalars("iteration", 1).with_data(iteration.to_vec()),
                        ],
                        cell: Vec::new(),
                    },
                    ..Default::default()
                }))],
            },
        };
        let mut out = Vec::new();
        vtk.write_xml(&mut out).unwrap();
        out
    }

    /// The streamed frames are byte for byte what vtkio writes for the same
    /// data, on a unit sphere and on a jittered 40-unit one (ranges of other
    /// magnitudes), and so are the remesh events, none and some.
    #[test]
    fn the_streamed_vtk_xml_is_byte_for_byte_vtkios() {
        let mut big = crate::mesh::icosphere(3, 40.0);
        big.jitter(0.3, 5);
        for mesh in [crate::mesh::icosphere_unit(2), big] {
            let data = frame_data(&mesh);
            let mut ours = Vec::new();
            write_frame_vtp(&mut ours, &mesh.positions, &mesh.faces, &data).unwrap();
            let theirs = vtkio_frame(&mesh, &data);
            assert!(
                ours == theirs,
                "frames differ:\n{}\n{}",
                String::from_utf8_lossy(&ours[..300.min(ours.len())]),
                String::from_utf8_lossy(&theirs[..300.min(theirs.len())])
            );
        }
        for n in [0u64, 5] {
            let points: Vec<glam::DVec3> = (0..n)
                .map(|i| glam::DVec3::new(i as f64, -0.5, 2.0))
                .collect();
            let split: Vec<u8> = (0..n).map(|i| (i % 2) as u8).collect();
            let iteration: Vec<u64> = (0..n).map(|i| 100 * i).collect();
            let mut ours = Vec::new();
            let arrays = [
                DataArray {
                    name: "split",
                    values: Values::U8(&split),
                },
                DataArray {
                    name: "iteration",
                    values: Values::U64(&iteration),
                },
            ];
            write_poly_data(&mut ours, &points, Cells::PointVertices, &arrays).unwrap();
            let theirs = vtkio_events(&points, &split, &iteration);
            assert!(
                ours == theirs,
                "{n} events differ:\n{}\n{}",
                String::from_utf8_lossy(&ours),
                String::from_utf8_lossy(&theirs)
            );
        }
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
        let vtkio::model::DataSet::PolyData { pieces, .. } = vtk.data else {
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
