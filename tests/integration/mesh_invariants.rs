//! The invariant checker rejects each kind of broken mesh and names the
//! offending element; generators, docking, I/O and the topology cache keep
//! valid meshes valid.

use glam::DVec3;
use remembrane::mesh::io::{MeshIoError, read_mesh, write_mesh};
use remembrane::mesh::membrane::Membrane;
use remembrane::mesh::{MeshError, SurfaceMesh, ValenceRange, check_mesh, docked_pair, icosphere};

use crate::common::torus;

fn sphere() -> SurfaceMesh {
    icosphere(1, 1.0)
}

fn check(m: &SurfaceMesh) -> Result<remembrane::mesh::MeshReport, MeshError> {
    check_mesh(&m.positions, &m.faces, None)
}

#[test]
fn valid_meshes_pass() {
    let r = check(&sphere()).unwrap();
    assert_eq!(
        (r.vertices, r.edges, r.faces, r.components),
        (42, 120, 80, 1)
    );
    let two = {
        let mut a = icosphere(1, 1.0);
        let mut b = icosphere(1, 1.0);
        b.translate(DVec3::new(10.0, 0.0, 0.0));
        let off = a.positions.len() as u32;
        a.positions.extend(b.positions);
        a.faces.extend(b.faces.iter().map(|f| f.map(|v| v + off)));
        a
    };
    assert_eq!(check(&two).unwrap().components, 2);
}

#[test]
fn accepts_open_mesh_with_its_loop() {
    // Open meshes are valid (tests/integration/open_mesh.rs has their broken kinds).
    let mut m = sphere();
    m.faces.remove(7);
    assert_eq!(check(&m).unwrap().boundary_loops, 1);
}

#[test]
fn rejects_flipped_face() {
    let mut m = sphere();
    m.faces[3].swap(1, 2);
    match check(&m).unwrap_err() {
        MeshError::InconsistentOrientation { first, second, .. } => {
            assert!(first == 3 || second == 3)
        }
        e => panic!("expected InconsistentOrientation, got {e}"),
    }
}

#[test]
fn rejects_non_manifold_edge() {
    let mut m = sphere();
    let [a, b, _] = m.faces[0];
    m.positions.push(DVec3::new(50.0, 50.0, 50.0));
    let x = (m.positions.len() - 1) as u32;
    m.faces.push([b, a, x]);
    match check(&m).unwrap_err() {
        MeshError::NonManifoldEdge {
            a: ea,
            b: eb,
            count,
        } => {
            assert_eq!((ea.min(eb), ea.max(eb), count), (a.min(b), a.max(b), 3));
        }
        e => panic!("expected NonManifoldEdge, got {e}"),
    }
}

#[test]
fn rejects_non_manifold_vertex() {
    // Two spheres pinched together at one shared vertex: b is a's point
    // reflection through a's vertex 0, so b's vertex 0 coincides with it.
    let mut a = sphere();
    let mut b = sphere();
    let pin = a.positions[0];
    for p in &mut b.positions {
        *p = 2.0 * pin - *p;
    }
    let off = a.positions.len() as u32;
    let remap = |v: u32| if v == 0 { 0 } else { v + off - 1 };
    a.positions.extend(b.positions.iter().skip(1));
    // Point reflection reverses orientation: flip b's faces back outward.
    a.faces.extend(
        b.faces
            .iter()
            .map(|f| [remap(f[0]), remap(f[2]), remap(f[1])]),
    );
    match check(&a).unwrap_err() {
        MeshError::NonManifoldVertex { vertex, fans } => assert_eq!((vertex, fans), (0, 2)),
        e => panic!("expected NonManifoldVertex, got {e}"),
    }
}

#[test]
fn rejects_duplicate_face() {
    let mut m = sphere();
    let f = m.faces[5];
    m.faces.push([f[1], f[2], f[0]]);
    match check(&m).unwrap_err() {
        MeshError::DuplicateFace { first, second, .. } => assert_eq!((first, second), (5, 80)),
        e => panic!("expected DuplicateFace, got {e}"),
    }
}

#[test]
fn rejects_degenerate_face() {
    let mut m = sphere();
    let [a, b, c] = m.faces[9];
    // Put c on the segment ab: zero area, still distinct vertices.
    m.positions[c as usize] = 0.5 * (m.positions[a as usize] + m.positions[b as usize]);
    match check(&m).unwrap_err() {
        MeshError::DegenerateFace { face, area, .. } => {
            assert!(m.faces[face].contains(&c));
            assert!(area < 1e-12);
        }
        e => panic!("expected DegenerateFace, got {e}"),
    }
}

#[test]
fn rejects_nan_coordinate() {
    let mut m = sphere();
    m.positions[17].y = f64::NAN;
    assert!(matches!(
        check(&m).unwrap_err(),
        MeshError::NonFiniteVertex { vertex: 17, .. }
    ));
    m.positions[17].y = f64::INFINITY;
    assert!(matches!(
        check(&m).unwrap_err(),
        MeshError::NonFiniteVertex { vertex: 17, .. }
    ));
}

#[test]
fn rejects_wrong_euler_characteristic_and_inward_orientation() {
    match check(&torus(8, 6)).unwrap_err() {
        MeshError::WrongEulerCharacteristic { chi, .. } => assert_eq!(chi, 0),
        e => panic!("expected WrongEulerCharacteristic, got {e}"),
    }
    let mut m = sphere();
    for f in &mut m.faces {
        f.swap(1, 2);
    }
    assert!(matches!(
        check(&m).unwrap_err(),
        MeshError::InwardOrientation { component: 0, .. }
    ));
}

#[test]
fn rejects_out_of_range_index_and_valence() {
    let mut m = sphere();
    m.faces[2][1] = 999;
    assert!(matches!(
        check(&m).unwrap_err(),
        MeshError::FaceIndexOutOfRange {
            face: 2,
            index: 999,
            ..
        }
    ));
    let m = sphere();
    let err = check_mesh(
        &m.positions,
        &m.faces,
        Some(ValenceRange { min: 6, max: 6 }),
    )
    .unwrap_err();
    assert!(
        matches!(err, MeshError::ValenceOutOfRange { valence: 5, .. }),
        "{err}"
    );
}

#[test]
fn docked_pair_is_a_valid_321_vertex_sphere() {
    let m = docked_pair(2);
    let r = check_mesh(
        &m.positions,
        &m.faces,
        Some(ValenceRange { min: 5, max: 10 }),
    )
    .unwrap();
    assert_eq!(
        (r.vertices, r.edges, r.faces, r.components),
        (321, 957, 638, 1)
    );
    // The three neck vertices carry both spheres' fans.
    assert_eq!(r.valences.iter().filter(|&&v| v > 8).count(), 3);
}

#[test]
fn ply_and_obj_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = icosphere(2, 1.0);
    m.jitter(0.01, 3);
    for name in ["m.ply", "m.obj"] {
        let path = dir.path().join(name);
        write_mesh(&path, &m).unwrap();
        let back = read_mesh(&path).unwrap();
        // tobj numbers OBJ vertices by first use: compare faces as corner positions.
        let corners = |m: &SurfaceMesh| -> Vec<[[u64; 3]; 3]> {
            m.faces
                .iter()
                .map(|f| f.map(|v| m.positions[v as usize].to_array().map(f64::to_bits)))
                .collect()
        };
        assert_eq!(corners(&back), corners(&m), "{name}");
    }
}

#[test]
fn broken_mesh_files_are_rejected_with_path_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let mut flipped = sphere();
    flipped.faces[2].swap(0, 1);
    let path = dir.path().join("flipped.obj");
    std::fs::write(&path, obj_text(&flipped)).unwrap();
    let err = read_mesh(&path).unwrap_err();
    assert!(matches!(
        err,
        MeshIoError::Invalid {
            source: MeshError::InconsistentOrientation { .. },
            ..
        }
    ));
    assert!(
        err.to_string().contains("flipped.obj") && err.to_string().contains("orientation"),
        "{err}"
    );

    let path = dir.path().join("garbage.ply");
    std::fs::write(
        &path,
        "ply\nformat ascii 1.0\nelement vertex 2\nend_header\n1 2\n",
    )
    .unwrap();
    let err = read_mesh(&path).unwrap_err();
    assert!(err.to_string().contains("garbage.ply"), "{err}");

    let path = dir.path().join("quad.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
    let err = read_mesh(&path).unwrap_err();
    assert!(err.to_string().contains("triangulated"), "{err}");
}

fn obj_text(m: &SurfaceMesh) -> String {
    let mut buf = Vec::new();
    remembrane::mesh::io::write_obj_to(&mut buf, m).unwrap();
    String::from_utf8(buf).unwrap()
}

#[test]
fn topology_cache_matches_mesh() {
    let mesh = icosphere(2, 1.0);
    let mut membrane = Membrane::from_mesh(&mesh, true).unwrap();
    let t = membrane.topology().unwrap().clone();
    assert_eq!(t.faces, mesh.faces);
    assert_eq!(t.edges.len(), 480);
    for (e, &[a, b]) in t.edges.iter().enumerate() {
        let [fl, fr] = t.edge_faces[e];
        // Left face traverses a → b, right face b → a.
        let has = |f: u32, x: u32, y: u32| {
            (0..3).any(|k| t.faces[f as usize][k] == x && t.faces[f as usize][(k + 1) % 3] == y)
        };
        assert!(has(fl, a, b) && has(fr, b, a));
    }
    for v in 0..t.vertex_count() {
        let ring = t.neighbours(v);
        let (ring_faces, ring_edges) = (t.ring_faces_of(v), t.ring_edges_of(v));
        for k in 0..ring.len() {
            let next = ring[(k + 1) % ring.len()];
            assert_eq!(
                rotate_to(t.faces[ring_faces[k] as usize], v as u32),
                [v as u32, ring[k], next]
            );
            let [a, b] = t.edges[ring_edges[k] as usize];
            assert!((a, b) == (v as u32, ring[k]) || (b, a) == (v as u32, ring[k]));
        }
    }
    let back = membrane.to_mesh().unwrap();
    assert_eq!(back, mesh);
}

fn rotate_to(f: [u32; 3], v: u32) -> [u32; 3] {
    let k = f.iter().position(|&x| x == v).unwrap();
    [f[k], f[(k + 1) % 3], f[(k + 2) % 3]]
}
