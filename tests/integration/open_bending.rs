//! Bending on open meshes (issue 32 item 2): boundary vertices carry no
//! bending energy of their own and the interior discretisation is
//! unchanged, so a flat patch has zero bending force and a cap cut from a
//! sphere has the sphere's forces at every vertex two rings or more from
//! its rim; in the cotangent and the dihedral form.

use glam::DVec3;
use remembrane::energy::bending::{BendingScratch, bending, bending_open};
use remembrane::energy::bending_dihedral::bending_dihedral;
use remembrane::mesh::geometry::Corners;
use remembrane::mesh::membrane::Membrane;
use remembrane::mesh::{SurfaceMesh, check_mesh, disc, icosphere};

fn geometry(m: &SurfaceMesh) -> Vec<Corners> {
    m.faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| m.positions[v as usize]);
            Corners::new(a, b, c)
        })
        .collect()
}

/// Energy and forces of the dihedral bending on `m` (open or closed).
fn dihedral_forces(m: &SurfaceMesh, kappa: f64, c0: f64) -> (f64, Vec<DVec3>) {
    let mut membrane = Membrane::from_mesh(m, false).unwrap();
    let t = membrane.topology().unwrap().clone();
    assert_eq!(t.faces, m.faces);
    let mut f = vec![DVec3::ZERO; m.vertex_count()];
    let e = bending_dihedral(
        &m.positions,
        &t,
        &geometry(m),
        kappa,
        c0,
        &mut Default::default(),
        Some(&mut f),
    );
    (e, f)
}

/// Energy and forces of the cotangent bending on `m` (open or closed).
fn forces(m: &SurfaceMesh, kappa: f64, c0: f64) -> (f64, Vec<DVec3>) {
    let mut membrane = Membrane::from_mesh(m, false).unwrap();
    let boundary = membrane.topology().unwrap().boundary_mask();
    let open = boundary.iter().any(|&b| b);
    let mut f = vec![DVec3::ZERO; m.vertex_count()];
    let mut scratch = BendingScratch::default();
    let e = bending_open(
        m.vertex_count(),
        &m.faces,
        &geometry(m),
        kappa,
        c0,
        open.then_some(&boundary[..]),
        &mut scratch,
        Some(&mut f),
    );
    (e, f)
}

#[test]
fn a_flat_patch_has_no_bending_energy_or_force() {
    let m = disc(5.0, 1.0);
    for (e, f) in [forces(&m, 5.0, 0.0), dihedral_forces(&m, 5.0, 0.0)] {
        let max = f.iter().map(|v| v.length()).fold(0.0, f64::max);
        assert!(e.abs() < 1e-20, "{e}");
        assert!(max < 1e-12, "max |F| = {max}");
    }
    // Without the boundary rule the rim's Laplacians point across the rim:
    // the same patch would have energy and force.
    let mut closed_rule = vec![DVec3::ZERO; m.vertex_count()];
    let e_all = bending(
        m.vertex_count(),
        &m.faces,
        &geometry(&m),
        5.0,
        0.0,
        &mut BendingScratch::default(),
        Some(&mut closed_rule),
    );
    assert!(e_all > 1.0, "{e_all}");
}

#[test]
fn a_cap_cut_from_a_sphere_has_the_sphere_forces_inside() {
    let sphere = icosphere(3, 1.0);
    // Keep the faces whose corners all lie above z = −2 (of radius 6.6).
    let keep: Vec<[u32; 3]> = sphere
        .faces
        .iter()
        .copied()
        .filter(|f| f.iter().all(|&v| sphere.positions[v as usize].z > -2.0))
        .collect();
    let mut used: Vec<u32> = keep.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    let new_of = |v: u32| used.binary_search(&v).unwrap() as u32;
    let cap = SurfaceMesh {
        positions: used.iter().map(|&v| sphere.positions[v as usize]).collect(),
        faces: keep.iter().map(|f| f.map(new_of)).collect(),
    };
    let report = check_mesh(&cap.positions, &cap.faces, None).unwrap();
    assert_eq!(report.boundary_loops, 1);
    let mut membrane = Membrane::from_mesh(&cap, false).unwrap();
    let t = membrane.topology().unwrap().clone();
    // Graph distance ≥ 2 from the rim: neither the vertex nor a neighbour
    // is on it.
    let deep: Vec<usize> = (0..cap.vertex_count())
        .filter(|&v| {
            !t.is_boundary_vertex(v)
                && t.neighbours(v)
                    .iter()
                    .all(|&w| !t.is_boundary_vertex(w as usize))
        })
        .collect();
    assert!(deep.len() > cap.vertex_count() / 2, "{}", deep.len());
    for (c0, dihedral) in [(0.0, false), (0.15, false), (0.0, true), (0.15, true)] {
        let (f_cap, f_sphere) = if dihedral {
            (
                dihedral_forces(&cap, 5.0, c0).1,
                dihedral_forces(&sphere, 5.0, c0).1,
            )
        } else {
            let mut f_sphere = vec![DVec3::ZERO; sphere.vertex_count()];
            bending(
                sphere.vertex_count(),
                &sphere.faces,
                &geometry(&sphere),
                5.0,
                c0,
                &mut BendingScratch::default(),
                Some(&mut f_sphere),
            );
            (forces(&cap, 5.0, c0).1, f_sphere)
        };
        let scale = f_sphere.iter().map(|v| v.length()).fold(0.0, f64::max);
        assert!(scale > 1e-3);
        let worst = deep
            .iter()
            .map(|&v| (f_cap[v] - f_sphere[used[v] as usize]).length())
            .fold(0.0, f64::max);
        println!("c0 {c0} dihedral {dihedral}: max |ΔF| {worst:.2e} of max |F| {scale:.3e}");
        assert!(worst <= 1e-12 * scale.max(1.0), "{worst}");
        // And the rim's neighbours differ: the test can fail.
        let rim_next = (0..cap.vertex_count())
            .find(|&v| !t.is_boundary_vertex(v) && !deep.contains(&v))
            .unwrap();
        let d = (f_cap[rim_next] - f_sphere[used[rim_next] as usize]).length();
        assert!(d > 1e-6 * scale, "{d}");
    }
}
