//! Run outputs (SPEC §7): VTK PolyData frames (`frames/*.vtp`) with a `.pvd`
//! collection for ParaView, `series.csv` (one row per frame), `final.ply`,
//! `final.png` (side and top view) and `summary.json`.
//!
//! A run writes into `DIR.incomplete/` and renames it to `DIR` only when it
//! ends (completed or stopped by a blow-up, which `summary.json` records),
//! so a killed run never leaves a directory that looks like a result. Every
//! file is written atomically (temporary file + rename).

use crate::atomic_write;
use crate::force::ForceBuffers;
use crate::geometry::curvature_vectors;
use crate::mesh::SurfaceMesh;
use crate::mesh::io::{VertexScalar, write_ply_to};
use crate::remesh::RemeshStats;
use crate::simulation::{DenseLipid, DensePositions, Simulation};
use crate::systems::barrier_check::AbnormalEdges;
use crate::timestep::TimeStepChoice;
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
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FrameRecord {
    /// Iteration of the frame.
    pub iteration: u64,
    /// Simulated time (s).
    pub time: f64,
    /// Path relative to the run directory.
    pub file: String,
}

/// The directory a run writes into.
pub struct RunOutput {
    dir: PathBuf,
    staging: PathBuf,
    /// Frames written so far.
    pub frames: Vec<FrameRecord>,
    series_header: Option<String>,
    series: String,
    probes: Vec<crate::tube_radius::TubeProbe>,
    first_radius: Vec<Option<f64>>,
}

impl RunOutput {
    /// Prepares `dir` (via `dir.incomplete`). An existing `dir` is an error
    /// unless `overwrite`, in which case it is removed first.
    pub fn create(dir: &Path, overwrite: bool) -> Result<Self, OutputError> {
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
        std::fs::create_dir_all(staging.join("frames")).map_err(|e| write_err(&staging, e))?;
        Ok(Self {
            dir: dir.to_owned(),
            staging,
            frames: Vec::new(),
            series_header: None,
            series: String::new(),
            probes: Vec::new(),
            first_radius: Vec::new(),
        })
    }

    /// Tubes whose radius every frame measures; `_norm` columns divide by
    /// the first frame's radius.
    pub fn set_tube_probes(&mut self, probes: Vec<crate::tube_radius::TubeProbe>) {
        self.first_radius = vec![None; probes.len()];
        self.probes = probes;
    }

    /// The final run directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn write(&self, relative: &str, bytes: &[u8]) -> Result<(), OutputError> {
        let path = self.staging.join(relative);
        atomic_write(&path, bytes).map_err(|e| write_err(&path, e))
    }

    /// Writes the state as frame `frames/frame_NNNNNN.vtp`, adds it to the
    /// `.pvd` collection and appends a row to `series.csv`. Point data:
    /// `force` (total, Ē/l̄), `mean_curvature` |K| (1/l̄) and `density` when
    /// the scene has lipid density.
    pub fn write_frame(&mut self, name: &str, sim: &Simulation) -> Result<(), OutputError> {
        let membrane = sim.membrane();
        let t = membrane.cached_topology();
        let clock = sim.clock();
        let positions = sim.resource::<DensePositions>();
        let lipid = sim.resource::<DenseLipid>();
        let file = format!("frames/frame_{:06}.vtp", clock.iteration);
        let bytes = frame_vtp(
            name,
            &positions.0,
            &t.faces,
            &sim.resource::<ForceBuffers>().evaluation.total,
            &lipid.0,
        )
        .map_err(|e| write_err(&self.staging.join(&file), e))?;
        self.write(&file, &bytes)?;
        self.frames.push(FrameRecord {
            iteration: clock.iteration,
            time: clock.time,
            file,
        });
        self.write("run.pvd", pvd(&self.frames).as_bytes())?;
        let (mut header, mut row) = series_row(sim);
        for (probe, first) in self.probes.iter().zip(&mut self.first_radius) {
            let r = probe.measure(&positions.0, &t.edges).map(|(r, _)| r);
            if first.is_none() {
                *first = r;
            }
            let norm = match (r, *first) {
                (Some(r), Some(r0)) => r / r0,
                _ => f64::NAN,
            };
            header += &format!(",radius_{0},radius_{0}_norm", probe.name);
            row += &format!(",{:e},{norm:e}", r.unwrap_or(f64::NAN));
        }
        if self.series_header.is_none() {
            self.series = header.clone() + "\n";
            self.series_header = Some(header);
        }
        self.series += &row;
        self.series.push('\n');
        self.write("series.csv", self.series.as_bytes())
    }

    /// Writes the remesh events as `events.vtp` (one vertex per event, point
    /// data `split` = 1/0 and `iteration`, for ParaView) and `events.csv`.
    pub fn write_events(&self, events: &[crate::remesh::RemeshEvent]) -> Result<(), OutputError> {
        let mut csv = String::from("iteration,kind,x,y,z\n");
        for e in events {
            let kind = if e.split { "split" } else { "merge" };
            let [x, y, z] = e.position;
            csv += &format!("{},{kind},{x:e},{y:e},{z:e}\n", e.iteration);
        }
        self.write("events.csv", csv.as_bytes())?;
        let n = events.len() as u64;
        let vtk = Vtk {
            version: Version { major: 1, minor: 0 },
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
                                    .map(|e| u8::from(e.split))
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
        vtk.write_xml(&mut out)
            .map_err(|e| write_err(&self.staging.join("events.vtp"), e))?;
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
        let png = crate::render::render_png(&final_mesh.positions, &final_mesh.faces, 400);
        self.write("final.png", &png)?;
        if let Some(state) = state_json {
            self.write("state.json", state.as_bytes())?;
        }
        self.write("summary.json", summary_json.as_bytes())?;
        std::fs::rename(&self.staging, &self.dir).map_err(|e| write_err(&self.dir, e))?;
        Ok(self.dir)
    }
}

/// A VTK XML PolyData document of a triangle mesh with point data.
pub fn frame_vtp(
    title: &str,
    positions: &[glam::DVec3],
    faces: &[[u32; 3]],
    force: &[glam::DVec3],
    density: &[f64],
) -> Result<Vec<u8>, vtkio::Error> {
    let points: Vec<f64> = positions.iter().flat_map(|p| p.to_array()).collect();
    let connectivity: Vec<u64> = faces.iter().flat_map(|f| f.map(u64::from)).collect();
    let offsets: Vec<u64> = (1..=faces.len() as u64).map(|i| 3 * i).collect();
    let curvature: Vec<f64> = curvature_vectors(positions, faces)
        .iter()
        .map(|k| k.length())
        .collect();
    let mut point = vec![
        Attribute::vectors("force").with_data(
            force
                .iter()
                .flat_map(|f| f.to_array())
                .collect::<Vec<f64>>(),
        ),
        Attribute::scalars("mean_curvature", 1).with_data(curvature),
    ];
    if !density.is_empty() {
        point.push(Attribute::scalars("density", 1).with_data(density.to_vec()));
    }
    let vtk = Vtk {
        version: Version { major: 1, minor: 0 },
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
    let mut out = Vec::new();
    vtk.write_xml(&mut out)?;
    Ok(out)
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

/// The `series.csv` header and the row for the current state.
pub fn series_row(sim: &Simulation) -> (String, String) {
    let membrane = sim.membrane();
    let t = membrane.cached_topology();
    let positions = sim.resource::<DensePositions>();
    let p = &positions.0;
    let area = crate::geometry::total_area(p, &t.faces);
    let volume = crate::geometry::enclosed_volume(p, &t.faces, p[0]);
    let (mut lmin, mut lmax) = (f64::INFINITY, 0.0f64);
    for &[a, b] in &t.edges {
        let l = p[a as usize].distance(p[b as usize]);
        lmin = lmin.min(l);
        lmax = lmax.max(l);
    }
    let buffers = sim.resource::<ForceBuffers>();
    let mut header = String::from("iteration,time,dt,vertices");
    let c = sim.clock();
    let mut row = format!(
        "{},{:e},{:e},{}",
        c.iteration,
        c.time,
        sim.resource::<TimeStepChoice>().dt,
        t.vertex_count()
    );
    for (term, e) in buffers.terms().iter().zip(&buffers.evaluation.energies) {
        header += &format!(",energy_{}", term.name);
        row += &format!(",{e:e}");
    }
    let stats = sim.resources().get::<RemeshStats>().ok();
    let none = RemeshStats::default();
    let stats = stats.as_deref().unwrap_or(&none);
    header += ",energy_total,area,volume,reduced_volume,edge_min,edge_max,abnormal_edges,splits,merges,remesh_spread";
    row += &format!(
        ",{:e},{:e},{:e},{:e},{:e},{:e},{},{},{},{:e}",
        buffers.evaluation.total_energy(),
        area,
        volume,
        crate::geometry::reduced_volume(volume, area),
        lmin,
        lmax,
        sim.resource::<AbnormalEdges>().0.len(),
        stats.split.success,
        stats.merge.success,
        stats.position_spread()
    );
    (header, row)
}
