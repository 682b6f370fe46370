//! One frame as VTK XML PolyData (`.vtp`), written whole, and the `.pvd`
//! collection of the frames.

use super::*;

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
pub(super) fn write_vtk_xml(vtk: Vtk, writer: impl std::io::Write) -> Result<(), vtkio::Error> {
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
pub(super) struct WriteAll<W> {
    pub(super) inner: W,
    pub(super) error: Option<std::io::Error>,
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
pub(super) fn pvd(frames: &[FrameRecord]) -> String {
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
