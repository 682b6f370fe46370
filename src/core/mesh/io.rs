//! PLY and OBJ import/export. Import validates the mesh with
//! [`check_mesh`] (valence limits are the scene's business).

use super::{MeshError, SurfaceMesh, check_mesh};
use glam::DVec3;
use ply_rs_bw::ply::{
    Addable, DefaultElement, ElementDef, Encoding, Ply, Property, PropertyAccess, PropertyDef,
    PropertyType, ScalarType,
};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A mesh file could not be read, parsed or accepted.
#[derive(Debug, thiserror::Error)]
pub enum MeshIoError {
    /// The file could not be opened or read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// File path.
        path: PathBuf,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("{path}: cannot write: {source}")]
    Write {
        /// File path.
        path: PathBuf,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// The file's extension is neither `.ply` nor `.obj`.
    #[error("{path}: unknown mesh format (expected a .ply or .obj file)")]
    UnknownFormat {
        /// File path.
        path: PathBuf,
    },
    /// The file is not valid PLY/OBJ or lacks required data.
    #[error("{path}: {reason}")]
    Parse {
        /// File path.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The file parsed, but the mesh breaks a membrane invariant.
    #[error("{path}: invalid membrane mesh: {source}")]
    Invalid {
        /// File path.
        path: PathBuf,
        /// The violated invariant.
        source: MeshError,
    },
}

/// Reads a `.ply` (ASCII or binary) or `.obj` triangle mesh and checks it
/// with [`check_mesh`]: manifold and consistently oriented, closed
/// (outward) or open. An OBJ's vertices come numbered in the order its
/// faces first use them (the OBJ reader's indexing); a PLY keeps its order.
pub fn read_mesh(path: &Path) -> Result<SurfaceMesh, MeshIoError> {
    // Report a missing or unreadable file as such, not as a parse error.
    std::fs::File::open(path).map_err(|source| MeshIoError::Read {
        path: path.to_owned(),
        source,
    })?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mesh = match ext.as_deref() {
        Some("ply") => read_ply(path)?,
        Some("obj") => read_obj(path)?,
        _ => {
            return Err(MeshIoError::UnknownFormat {
                path: path.to_owned(),
            });
        }
    };
    check_mesh(&mesh.positions, &mesh.faces, None).map_err(|source| MeshIoError::Invalid {
        path: path.to_owned(),
        source,
    })?;
    Ok(mesh)
}

fn parse_err(path: &Path, reason: impl Into<String>) -> MeshIoError {
    MeshIoError::Parse {
        path: path.to_owned(),
        reason: reason.into(),
    }
}

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v as f64,
        Property::UChar(v) => v as f64,
        Property::Short(v) => v as f64,
        Property::UShort(v) => v as f64,
        Property::Int(v) => v as f64,
        Property::UInt(v) => v as f64,
        Property::Float(v) => v as f64,
        Property::Double(v) => v,
        _ => return None,
    })
}

fn index_list(p: &Property) -> Option<Vec<i64>> {
    Some(match p {
        Property::ListChar(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListUChar(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListShort(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListUShort(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListInt(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListUInt(v) => v.iter().map(|&x| x as i64).collect(),
        _ => return None,
    })
}

fn read_ply(path: &Path) -> Result<SurfaceMesh, MeshIoError> {
    let mut file =
        std::io::BufReader::new(
            std::fs::File::open(path).map_err(|source| MeshIoError::Read {
                path: path.to_owned(),
                source,
            })?,
        );
    let ply = ply_rs_bw::parser::Parser::<DefaultElement>::new()
        .read_ply(&mut file)
        .map_err(|e| parse_err(path, format!("not a valid PLY file: {e}")))?;
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| parse_err(path, "no `vertex` element"))?;
    let mut positions = Vec::with_capacity(vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        let coord = |name: &str| {
            v.get(name).and_then(scalar).ok_or_else(|| {
                parse_err(
                    path,
                    format!("vertex {i}: missing or non-numeric property `{name}`"),
                )
            })
        };
        positions.push(DVec3::new(coord("x")?, coord("y")?, coord("z")?));
    }
    let face_elems = ply
        .payload
        .get("face")
        .ok_or_else(|| parse_err(path, "no `face` element"))?;
    let mut faces = Vec::with_capacity(face_elems.len());
    for (i, f) in face_elems.iter().enumerate() {
        let list = f
            .get("vertex_indices")
            .or_else(|| f.get("vertex_index"))
            .and_then(index_list)
            .ok_or_else(|| parse_err(path, format!("face {i}: missing `vertex_indices` list")))?;
        faces.push(triangle(path, i, &list, positions.len())?);
    }
    Ok(SurfaceMesh { positions, faces })
}

fn triangle(path: &Path, face: usize, list: &[i64], n: usize) -> Result<[u32; 3], MeshIoError> {
    if list.len() != 3 {
        return Err(parse_err(
            path,
            format!(
                "face {face} has {} vertices; membranes must be triangulated",
                list.len()
            ),
        ));
    }
    let mut tri = [0u32; 3];
    for (k, &idx) in list.iter().enumerate() {
        if idx < 0 || idx as usize >= n {
            return Err(parse_err(
                path,
                format!("face {face} refers to vertex {idx}, but the file has {n} vertices"),
            ));
        }
        tri[k] = idx as u32;
    }
    Ok(tri)
}

fn read_obj(path: &Path) -> Result<SurfaceMesh, MeshIoError> {
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj(path, &options)
        .map_err(|e| parse_err(path, format!("not a valid OBJ file: {e}")))?;
    let mut mesh = SurfaceMesh::default();
    let mut face_index = 0;
    for model in models {
        let m = model.mesh;
        let offset = mesh.positions.len() as i64;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2])),
        );
        let n = mesh.positions.len();
        if let Some(arity) = m.face_arities.iter().find(|&&a| a != 3) {
            return Err(parse_err(
                path,
                format!("a face has {arity} vertices; membranes must be triangulated"),
            ));
        }
        for tri in m.indices.chunks_exact(3) {
            let list: Vec<i64> = tri.iter().map(|&i| i as i64 + offset).collect();
            mesh.faces.push(triangle(path, face_index, &list, n)?);
            face_index += 1;
        }
    }
    if mesh.faces.is_empty() {
        return Err(parse_err(path, "no faces"));
    }
    Ok(mesh)
}

/// A per-vertex scalar written as an extra PLY vertex property.
pub struct VertexScalar<'a> {
    /// Property name.
    pub name: &'a str,
    /// One value per vertex.
    pub values: &'a [f64],
}

/// One PLY element as the writer reads it, without a map per element (a
/// `DefaultElement` costs about 300 bytes per vertex and per face: 40 MB
/// for a 40962-vertex mesh): a vertex (its slot, read from the mesh and the
/// scalars) or a face.
enum PlyRow<'a> {
    Vertex {
        position: DVec3,
        slot: usize,
        scalars: &'a [VertexScalar<'a>],
    },
    Face([i32; 3]),
}

impl PropertyAccess for PlyRow<'_> {
    fn new() -> Self {
        PlyRow::Face([0; 3])
    }

    fn get_double(&self, name: &str) -> Option<f64> {
        let PlyRow::Vertex {
            position,
            slot,
            scalars,
        } = self
        else {
            return None;
        };
        match name {
            "x" => Some(position.x),
            "y" => Some(position.y),
            "z" => Some(position.z),
            _ => scalars
                .iter()
                .find(|s| s.name == name)
                .map(|s| s.values[*slot]),
        }
    }

    fn get_list_int(&self, name: &str) -> Option<&[i32]> {
        match self {
            PlyRow::Face(corners) if name == "vertex_indices" => Some(corners),
            _ => None,
        }
    }
}

/// Writes a binary little-endian PLY with double-precision coordinates and
/// optional per-vertex scalars into `out`.
pub fn write_ply_to(
    out: &mut impl Write,
    mesh: &SurfaceMesh,
    scalars: &[VertexScalar<'_>],
    comment: &str,
) -> std::io::Result<()> {
    let mut ply = Ply::<PlyRow<'_>>::new();
    ply.header.encoding = Encoding::BinaryLittleEndian;
    if !comment.is_empty() {
        ply.header.comments.push(comment.to_string());
    }
    let mut vertex = ElementDef::new("vertex".to_string());
    for name in ["x", "y", "z"] {
        vertex.properties.add(PropertyDef::new(
            name.to_string(),
            PropertyType::Scalar(ScalarType::Double),
        ));
    }
    for s in scalars {
        vertex.properties.add(PropertyDef::new(
            s.name.to_string(),
            PropertyType::Scalar(ScalarType::Double),
        ));
    }
    ply.header.elements.add(vertex);
    let mut face = ElementDef::new("face".to_string());
    face.properties.add(PropertyDef::new(
        "vertex_indices".to_string(),
        PropertyType::List(ScalarType::UChar, ScalarType::Int),
    ));
    ply.header.elements.add(face);
    let vertices = mesh
        .positions
        .iter()
        .enumerate()
        .map(|(slot, &position)| PlyRow::Vertex {
            position,
            slot,
            scalars,
        })
        .collect();
    ply.payload.insert("vertex".to_string(), vertices);
    let faces = mesh
        .faces
        .iter()
        .map(|f| PlyRow::Face(f.map(|v| v as i32)))
        .collect();
    ply.payload.insert("face".to_string(), faces);
    ply_rs_bw::writer::Writer::new()
        .write_ply(out, &mut ply)
        .map(|_| ())
        .map_err(std::io::Error::other)
}

/// Writes a Wavefront OBJ (positions and 1-based triangle indices).
pub fn write_obj_to(out: &mut impl Write, mesh: &SurfaceMesh) -> std::io::Result<()> {
    writeln!(
        out,
        "# remembrane mesh: {} vertices, {} faces",
        mesh.positions.len(),
        mesh.faces.len()
    )?;
    for p in &mesh.positions {
        writeln!(out, "v {:.17e} {:.17e} {:.17e}", p.x, p.y, p.z)?;
    }
    for f in &mesh.faces {
        writeln!(out, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1)?;
    }
    Ok(())
}

/// Writes `mesh` to `path` (format from the extension), atomically: the data
/// goes to a temporary file in the same folder which is then renamed.
pub fn write_mesh(path: &Path, mesh: &SurfaceMesh) -> Result<(), MeshIoError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mut buf = Vec::new();
    let io = match ext.as_deref() {
        Some("ply") => write_ply_to(&mut buf, mesh, &[], "written by remembrane"),
        Some("obj") => write_obj_to(&mut buf, mesh),
        _ => {
            return Err(MeshIoError::UnknownFormat {
                path: path.to_owned(),
            });
        }
    };
    io.and_then(|_| crate::atomic_write(path, &buf))
        .map_err(|source| MeshIoError::Write {
            path: path.to_owned(),
            source,
        })
}
