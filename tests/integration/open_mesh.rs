//! Open meshes (issue 32, items 1 and 2): the invariant checker accepts
//! manifold patches with boundary loops and still rejects every kind of
//! broken mesh with boundaries present; the topology cache gives boundary
//! edges one face and boundary vertices an ordered open fan; bad open mesh
//! files are named with the reason.

use glam::DVec3;
use remembrane::mesh::io::{MeshIoError, read_mesh};
use remembrane::mesh::membrane::Membrane;
use remembrane::mesh::topology::NO_SLOT;
use remembrane::mesh::{
    MeshError, SurfaceMesh, ValenceRange, check_mesh, disc, icosphere, spherical_cap,
};

use crate::common::torus;

fn check(m: &SurfaceMesh) -> Result<remembrane::mesh::MeshReport, MeshError> {
    check_mesh(&m.positions, &m.faces, None)
}

/// Two discs side by side whose rims touch at one vertex (a bow-tie):
/// the second disc's vertex at angle π is merged into the first's at 0.
fn bow_tie() -> SurfaceMesh {
    let mut a = disc(3.0, 1.0);
    let b = disc(3.0, 1.0);
    let touch_a = (0..a.positions.len())
        .max_by(|&i, &j| a.positions[i].x.total_cmp(&a.positions[j].x))
        .unwrap() as u32;
    let touch_b = (0..b.positions.len())
        .min_by(|&i, &j| b.positions[i].x.total_cmp(&b.positions[j].x))
        .unwrap() as u32;
    let shift = a.positions[touch_a as usize] - b.positions[touch_b as usize];
    let off = a.positions.len() as u32;
    let remap = |v: u32| match v.cmp(&touch_b) {
        std::cmp::Ordering::Equal => touch_a,
        std::cmp::Ordering::Less => v + off,
        std::cmp::Ordering::Greater => v + off - 1,
    };
    a.positions.extend(
        b.positions
            .iter()
            .enumerate()
            .filter(|&(i, _)| i as u32 != touch_b)
            .map(|(_, &p)| p + shift),
    );
    a.faces.extend(b.faces.iter().map(|f| f.map(remap)));
    a
}

#[test]
fn open_meshes_pass_with_their_loops_counted() {
    let r = check(&disc(4.0, 1.0)).unwrap();
    assert_eq!((r.components, r.boundary_loops), (1, 1));
    // A sphere with one face removed: one loop of three edges.
    let mut holed = icosphere(2, 1.0);
    holed.faces.remove(7);
    let r = check(&holed).unwrap();
    assert_eq!(r.boundary_loops, 1);
    // An annulus (the disc without its centre's fan): two loops, χ = 0.
    let mut annulus = disc(4.0, 1.0);
    annulus.faces.retain(|f| !f.contains(&0));
    annulus.positions[0] = DVec3::ZERO;
    // The centre is now isolated: drop it.
    annulus.positions.remove(0);
    for f in &mut annulus.faces {
        *f = f.map(|v| v - 1);
    }
    let r = check(&annulus).unwrap();
    assert_eq!(r.boundary_loops, 2);
    // Closed meshes report no loops.
    assert_eq!(check(&icosphere(2, 1.0)).unwrap().boundary_loops, 0);
}

#[test]
fn boundary_valences_are_held_to_the_shifted_range() {
    let m = disc(4.0, 1.0);
    // Rim vertices have 3 or 4 neighbours: within 5..=8 shifted to 3..=6.
    check_mesh(&m.positions, &m.faces, Some(ValenceRange::default())).unwrap();
    let err = check_mesh(
        &m.positions,
        &m.faces,
        Some(ValenceRange { min: 6, max: 8 }),
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            MeshError::ValenceOutOfRange {
                boundary: true,
                valence: 3,
                min: 4,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("boundary vertex"), "{err}");
}

#[test]
fn broken_open_meshes_are_rejected() {
    let base = disc(4.0, 1.0);
    // Flipped face.
    let mut m = base.clone();
    m.faces[10].swap(1, 2);
    assert!(
        matches!(
            check(&m).unwrap_err(),
            MeshError::InconsistentOrientation { .. }
        ),
        "{:?}",
        check(&m)
    );
    // A flipped face on the rim has no neighbour across its boundary edge:
    // its other two edges still disagree with their neighbours.
    let mut m = base.clone();
    let last = m.faces.len() - 1;
    m.faces[last].swap(1, 2);
    assert!(matches!(
        check(&m).unwrap_err(),
        MeshError::InconsistentOrientation { .. }
    ));
    // Non-manifold boundary edge: a third face on a rim edge.
    let mut m = base.clone();
    let [a, b, _] = m.faces[last];
    m.positions.push(DVec3::new(0.0, 0.0, 9.0));
    m.positions.push(DVec3::new(0.0, 0.0, -9.0));
    let x = (m.positions.len() - 2) as u32;
    m.faces.push([b, a, x]);
    m.faces.push([a, b, x + 1]);
    assert!(matches!(
        check(&m).unwrap_err(),
        MeshError::NonManifoldEdge { count: 3, .. }
    ));
    // Duplicate face.
    let mut m = base.clone();
    let f = m.faces[3];
    m.faces.push([f[2], f[0], f[1]]);
    assert!(matches!(
        check(&m).unwrap_err(),
        MeshError::DuplicateFace { first: 3, .. }
    ));
    // NaN on a rim vertex.
    let mut m = base.clone();
    let rim = m.positions.len() - 1;
    m.positions[rim].x = f64::NAN;
    assert!(matches!(
        check(&m).unwrap_err(),
        MeshError::NonFiniteVertex { .. }
    ));
    // Two loops touching at one vertex.
    match check(&bow_tie()).unwrap_err() {
        MeshError::NonManifoldVertex { fans: 2, .. } => {}
        e => panic!("expected NonManifoldVertex, got {e}"),
    }
}

#[test]
fn a_holed_torus_is_not_a_sphere_with_holes() {
    // A torus with one face removed: χ = −1 with one loop.
    let SurfaceMesh {
        positions,
        mut faces,
    } = torus(8, 6);
    faces.pop();
    match check(&SurfaceMesh { positions, faces }).unwrap_err() {
        MeshError::WrongEulerCharacteristic {
            chi: -1,
            boundary_loops: 1,
            ..
        } => {}
        e => panic!("expected WrongEulerCharacteristic, got {e}"),
    }
}

#[test]
fn topology_of_an_open_patch() {
    for mesh in [disc(3.0, 1.0), spherical_cap(5.0, 50.0, 1.0)] {
        let mut membrane = Membrane::from_mesh(&mesh, false).unwrap();
        let t = membrane.topology().unwrap().clone();
        assert!(t.is_open());
        let has = |f: u32, x: u32, y: u32| {
            (0..3).any(|k| t.faces[f as usize][k] == x && t.faces[f as usize][(k + 1) % 3] == y)
        };
        let mut boundary_edges = 0;
        for (e, &[a, b]) in t.edges.iter().enumerate() {
            let [fl, fr] = t.edge_faces[e];
            assert!(has(fl, a, b));
            if fr == NO_SLOT {
                boundary_edges += 1;
                assert!(t.is_boundary_edge(e));
                assert!(t.is_boundary_vertex(a as usize) && t.is_boundary_vertex(b as usize));
            } else {
                assert!(has(fr, b, a));
            }
        }
        let loops = t.boundary_loops();
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].len(), boundary_edges);
        let on_loop = |v: u32| loops[0].contains(&v);
        for v in 0..t.vertex_count() {
            let ring = t.neighbours(v);
            let (ring_faces, ring_edges) = (t.ring_faces_of(v), t.ring_edges_of(v));
            assert_eq!(t.is_boundary_vertex(v), on_loop(v as u32));
            for k in 0..ring.len() {
                let [a, b] = t.edges[ring_edges[k] as usize];
                assert!((a, b) == (v as u32, ring[k]) || (b, a) == (v as u32, ring[k]));
                if ring_faces[k] == NO_SLOT {
                    // Only the last entry of a boundary fan, which ends on a
                    // boundary edge and starts on one.
                    assert!(t.is_boundary_vertex(v) && k == ring.len() - 1);
                    assert!(t.is_boundary_edge(ring_edges[k] as usize));
                    assert!(t.is_boundary_edge(ring_edges[0] as usize));
                    continue;
                }
                let next = ring[(k + 1) % ring.len()];
                let f = t.faces[ring_faces[k] as usize];
                let j = f.iter().position(|&x| x == v as u32).unwrap();
                assert_eq!(
                    [f[j], f[(j + 1) % 3], f[(j + 2) % 3]],
                    [v as u32, ring[k], next]
                );
            }
        }
        // The loop runs along its edges: each step is a boundary edge
        // whose face traverses it that way.
        for w in 0..loops[0].len() {
            let (a, b) = (loops[0][w], loops[0][(w + 1) % loops[0].len()]);
            let e = t.edge_between(a, b).unwrap() as usize;
            assert!(t.is_boundary_edge(e) && has(t.edge_faces[e][0], a, b));
        }
        assert_eq!(membrane.to_mesh().unwrap(), mesh);
    }
}

#[test]
fn bad_open_mesh_files_are_named_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, m: &SurfaceMesh| {
        let path = dir.path().join(name);
        remembrane::mesh::io::write_mesh(&path, m).unwrap();
        path
    };
    // A valid open patch reads back.
    let good = disc(3.0, 1.0);
    for name in ["patch.ply", "patch.obj"] {
        let back = read_mesh(&write(name, &good)).unwrap();
        assert_eq!(back.faces.len(), good.faces.len());
    }
    let mut flipped = good.clone();
    flipped.faces[4].swap(0, 1);
    let mut non_manifold = good.clone();
    let [a, b, _] = *non_manifold.faces.last().unwrap();
    non_manifold.positions.push(DVec3::splat(9.0));
    non_manifold.positions.push(DVec3::splat(-9.0));
    let x = (non_manifold.positions.len() - 2) as u32;
    non_manifold.faces.push([b, a, x]);
    non_manifold.faces.push([a, b, x + 1]);
    let mut nan = good.clone();
    nan.positions[5].y = f64::NAN;
    for (name, mesh, reason) in [
        ("flipped.ply", flipped, "orientation"),
        ("nonmanifold.obj", non_manifold, "not manifold"),
        ("bowtie.ply", bow_tie(), "not manifold"),
        ("nan.ply", nan, "non-finite"),
    ] {
        let path = write(name, &mesh);
        let err = read_mesh(&path).unwrap_err();
        assert!(matches!(err, MeshIoError::Invalid { .. }), "{err}");
        let msg = err.to_string();
        assert!(msg.contains(name) && msg.contains(reason), "{msg}");
    }
}
