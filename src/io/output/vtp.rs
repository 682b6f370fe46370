//! One frame as VTK XML PolyData (`.vtp`), written whole, and the `.pvd`
//! collection of the frames.

use super::*;

/// Writes a VTK XML PolyData document of a triangle mesh with point data
/// to `writer`, streamed ([`super::vtk_xml`]).
pub fn write_frame_vtp(
    writer: impl std::io::Write,
    positions: &[glam::DVec3],
    faces: &[[u32; 3]],
    point_data: &[PointArray],
) -> std::io::Result<()> {
    use super::vtk_xml::{Cells, DataArray, Values, write_poly_data};
    let arrays: Vec<DataArray<'_>> = point_data
        .iter()
        .map(|a| match a {
            PointArray::Vectors { name, values } => DataArray {
                name,
                values: Values::Vectors(values),
            },
            PointArray::Scalars { name, values } => DataArray {
                name,
                values: Values::F64(values),
            },
        })
        .collect();
    write_poly_data(writer, positions, Cells::Triangles(faces), &arrays)
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
