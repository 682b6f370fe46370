//! A streaming writer of VTK XML PolyData (`.vtp`): the document goes to
//! the sink element by element, each data array base64-encoded as it is
//! read from the simulation's own buffers, so a frame costs a few kB of
//! memory whatever the mesh size (the whole-document model of a general VTK
//! library held about 47 MB for a 40962-vertex frame).
//!
//! The format is VTK's inline binary XML: `header_type="UInt64"`, little
//! endian, each array one base64 stream of an 8-byte byte count and the
//! values, with `RangeMin`/`RangeMax` of its values. The elements and
//! attributes (quick-xml escapes them) are those ParaView and VTK's own
//! reader read; a test checks that the bytes equal the ones vtkio writes for
//! the same data.

use base64::engine::general_purpose::STANDARD;
use base64::write::EncoderWriter;
use glam::DVec3;
use quick_xml::Writer;
use quick_xml::events::{BytesEnd, BytesStart, Event};
use std::io::{self, Write};

/// The values of one data array, borrowed from where they live.
#[derive(Clone, Copy, Debug)]
pub enum Values<'a> {
    /// Three-component `Float64` vectors.
    Vectors(&'a [DVec3]),
    /// `Float64` scalars.
    F64(&'a [f64]),
    /// `UInt8` scalars.
    U8(&'a [u8]),
    /// `UInt64` scalars.
    U64(&'a [u64]),
    /// `UInt64` connectivity of triangles: the corners, face after face.
    Triangles(&'a [[u32; 3]]),
    /// `UInt64` connectivity 0, 1, …, n − 1 (one vertex per cell).
    Sequence(usize),
    /// `UInt64` offsets `step`, 2·`step`, …, n·`step` of n cells of `step`
    /// corners each.
    Offsets {
        /// Cells.
        cells: usize,
        /// Corners per cell.
        step: u64,
    },
}

impl Values<'_> {
    /// VTK's name of the value type.
    fn type_name(&self) -> &'static str {
        match self {
            Values::Vectors(_) | Values::F64(_) => "Float64",
            Values::U8(_) => "UInt8",
            _ => "UInt64",
        }
    }

    /// Components per tuple.
    fn components(&self) -> usize {
        match self {
            Values::Vectors(_) => 3,
            _ => 1,
        }
    }

    /// Number of scalar values (tuples × components).
    fn len(&self) -> usize {
        match *self {
            Values::Vectors(v) => 3 * v.len(),
            Values::F64(v) => v.len(),
            Values::U8(v) => v.len(),
            Values::U64(v) => v.len(),
            Values::Triangles(t) => 3 * t.len(),
            Values::Sequence(n) => n,
            Values::Offsets { cells, .. } => cells,
        }
    }

    /// Bytes per scalar value.
    fn width(&self) -> usize {
        match self {
            Values::U8(_) => 1,
            _ => 8,
        }
    }

    /// The smallest and largest scalar value, as VTK's `RangeMin` and
    /// `RangeMax` text (`None` without values).
    fn range(&self) -> Option<(String, String)> {
        fn of<T: Copy + Into<f64>>(it: impl Iterator<Item = T>) -> Option<(String, String)> {
            let mut range: Option<(f64, f64)> = None;
            for x in it {
                let x: f64 = x.into();
                range = Some(match range {
                    None => (x, x),
                    Some((lo, hi)) => (lo.min(x), hi.max(x)),
                });
            }
            range.map(|(lo, hi)| (lo.to_string(), hi.to_string()))
        }
        // Integers become f64 as VTK ranges are (exact below 2⁵³).
        let int = |x: u64| x as f64;
        match *self {
            Values::Vectors(v) => of(v.iter().flat_map(|p| p.to_array())),
            Values::F64(v) => of(v.iter().copied()),
            Values::U8(v) => of(v.iter().copied()),
            Values::U64(v) => of(v.iter().map(|&x| int(x))),
            Values::Triangles(t) => of(t.iter().flatten().copied()),
            Values::Sequence(n) => of((0..n as u64).map(int)),
            Values::Offsets { cells, step } => of((1..=cells as u64).map(|i| int(i * step))),
        }
    }

    /// Writes the values' little-endian bytes to `out`, a chunk at a time.
    fn write_bytes(&self, out: &mut impl Write) -> io::Result<()> {
        let mut chunk = Vec::with_capacity(CHUNK);
        let mut put = |bytes: &[u8], out: &mut dyn Write| -> io::Result<()> {
            chunk.extend_from_slice(bytes);
            if chunk.len() + 8 > CHUNK {
                out.write_all(&chunk)?;
                chunk.clear();
            }
            Ok(())
        };
        match *self {
            Values::Vectors(v) => {
                for x in v.iter().flat_map(|p| p.to_array()) {
                    put(&x.to_le_bytes(), out)?;
                }
            }
            Values::F64(v) => {
                for x in v {
                    put(&x.to_le_bytes(), out)?;
                }
            }
            Values::U8(v) => {
                for x in v {
                    put(&[*x], out)?;
                }
            }
            Values::U64(v) => {
                for x in v {
                    put(&x.to_le_bytes(), out)?;
                }
            }
            Values::Triangles(t) => {
                for &x in t.iter().flatten() {
                    put(&u64::from(x).to_le_bytes(), out)?;
                }
            }
            Values::Sequence(n) => {
                for x in 0..n as u64 {
                    put(&x.to_le_bytes(), out)?;
                }
            }
            Values::Offsets { cells, step } => {
                for i in 1..=cells as u64 {
                    put(&(i * step).to_le_bytes(), out)?;
                }
            }
        }
        out.write_all(&chunk)
    }
}

/// Bytes handed to the base64 encoder at a time (a multiple of 3 and 8).
const CHUNK: usize = 3 * 8 * 1024;

/// One named data array.
#[derive(Clone, Copy, Debug)]
pub struct DataArray<'a> {
    /// The array's name.
    pub name: &'a str,
    /// Its values.
    pub values: Values<'a>,
}

/// The cells of a PolyData piece.
#[derive(Clone, Copy, Debug)]
pub enum Cells<'a> {
    /// Triangles (`Polys`).
    Triangles(&'a [[u32; 3]]),
    /// One vertex cell per point (`Verts`), in point order.
    PointVertices,
}

/// Writes a VTK XML PolyData document of one piece: `points`, its `cells`
/// and the per-point `point_data` (the first scalar array and the first
/// vector array are named the active ones, as VTK expects).
pub fn write_poly_data(
    sink: impl Write,
    points: &[DVec3],
    cells: Cells<'_>,
    point_data: &[DataArray<'_>],
) -> io::Result<()> {
    let mut w = Writer::new(sink);
    let mut root = BytesStart::new("VTKFile");
    root.push_attribute(("type", "PolyData"));
    root.push_attribute(("version", "1.0"));
    root.push_attribute(("byte_order", "LittleEndian"));
    root.push_attribute(("header_type", "UInt64"));
    w.write_event(Event::Start(root))?;
    w.write_event(Event::Start(BytesStart::new("PolyData")))?;
    let mut piece = BytesStart::new("Piece");
    // Zero counts are left out, as vtkio leaves them out.
    let mut count = |name: &str, n: usize| {
        if n > 0 {
            piece.push_attribute((name, n.to_string().as_str()));
        }
    };
    count("NumberOfPoints", points.len());
    let (topology, cell_count, corners) = match cells {
        Cells::Triangles(t) => ("Polys", t.len(), 3),
        Cells::PointVertices => ("Verts", points.len(), 1),
    };
    count(&format!("NumberOf{topology}"), cell_count);
    w.write_event(Event::Start(piece))?;
    let mut data = BytesStart::new("PointData");
    let first = |vectors: bool| {
        point_data
            .iter()
            .find(|a| matches!(a.values, Values::Vectors(_)) == vectors)
    };
    if let Some(a) = first(false) {
        data.push_attribute(("Scalars", a.name));
    }
    if let Some(a) = first(true) {
        data.push_attribute(("Vectors", a.name));
    }
    w.write_event(Event::Start(data))?;
    for array in point_data {
        data_array(&mut w, array)?;
    }
    w.write_event(Event::End(BytesEnd::new("PointData")))?;
    w.write_event(Event::Start(BytesStart::new("Points")))?;
    data_array(
        &mut w,
        &DataArray {
            name: "Points",
            values: Values::Vectors(points),
        },
    )?;
    w.write_event(Event::End(BytesEnd::new("Points")))?;
    w.write_event(Event::Start(BytesStart::new(topology)))?;
    let connectivity = match cells {
        Cells::Triangles(t) => Values::Triangles(t),
        Cells::PointVertices => Values::Sequence(points.len()),
    };
    for array in [
        DataArray {
            name: "connectivity",
            values: connectivity,
        },
        DataArray {
            name: "offsets",
            values: Values::Offsets {
                cells: cell_count,
                step: corners,
            },
        },
    ] {
        data_array(&mut w, &array)?;
    }
    w.write_event(Event::End(BytesEnd::new(topology)))?;
    w.write_event(Event::End(BytesEnd::new("Piece")))?;
    w.write_event(Event::End(BytesEnd::new("PolyData")))?;
    w.write_event(Event::End(BytesEnd::new("VTKFile")))?;
    w.into_inner().flush()
}

/// One `DataArray` element: its attributes, then the base64 stream of the
/// byte count and the values.
fn data_array<W: Write>(w: &mut Writer<W>, array: &DataArray<'_>) -> io::Result<()> {
    let v = &array.values;
    let mut start = BytesStart::new("DataArray");
    start.push_attribute(("type", v.type_name()));
    start.push_attribute(("Name", array.name));
    if v.components() != 1 {
        start.push_attribute(("NumberOfComponents", v.components().to_string().as_str()));
    }
    start.push_attribute(("format", "binary"));
    if let Some((lo, hi)) = v.range() {
        start.push_attribute(("RangeMin", lo.as_str()));
        start.push_attribute(("RangeMax", hi.as_str()));
    }
    w.write_event(Event::Start(start))?;
    {
        let mut encoder = EncoderWriter::new(WriteAll(w.get_mut()), &STANDARD);
        let bytes = (v.len() * v.width()) as u64;
        encoder.write_all(&bytes.to_le_bytes())?;
        v.write_bytes(&mut encoder)?;
        encoder.finish()?;
    }
    w.write_event(Event::End(BytesEnd::new("DataArray")))
}

/// A sink whose `write` writes the whole buffer (`write_all`) or fails. The
/// base64 encoder answers a short write of its sink by taking no input
/// (`Ok(0)`), which `write_all` on the encoder would report as an error;
/// through this adapter its sink never writes short.
struct WriteAll<W>(W);

impl<W: Write> Write for WriteAll<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.0.write_all(buf)?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.0.flush()
    }
}
