//! Every term that runs on open meshes has its analytic force equal to
//! minus the finite-difference gradient of its energy on randomly perturbed
//! open patches (a spherical cap and a flat disc, `fd::perturbed_patches`),
//! boundary vertices included: relative error ≤ 1e-6 per vertex force
//! vector above the absolute floor stated per term (the round-off level of
//! the difference quotient), as in `tests/integration/force_fd.rs`.

use glam::DVec3;
use remembrane::energy::adhesion::{AdhesionForces, AdhesionParams};
use remembrane::energy::vin::{Segmentation, VinForm, VinParams};
use remembrane::energy::wall::{WallForces, WallParams, WallShape};
use remembrane::energy::{
    area::AreaForces, bending::BendingForces, local_tension::LocalTensionForces,
    self_avoidance::SelfAvoidanceForces, springs::SpringForces, tension::TensionForces,
    vin::VinForces,
};
use remembrane::engine::force::ForceTerm;
use remembrane::fd::{FdOptions, Stencil, check_force_term, perturbed_patches};
use remembrane::mesh::SurfaceMesh;
use remembrane::mesh::components::ControlPoint;
use remembrane::mesh::geometry::total_area;
use remembrane::mesh::membrane::Membrane;
use remembrane::params::{BendingDiscretisation, BendingParams, SpringCoupling};
use std::sync::Arc;

fn opts(abs_floor: f64) -> FdOptions {
    FdOptions {
        rel_tol: 1e-6,
        abs_floor,
        ..FdOptions::default()
    }
}

/// Checks `term` on `mesh` at every vertex; asserts the boundary vertices
/// feel a force (so they are really tested) and returns the report's
/// largest relative error.
fn check(name: &str, mesh: &SurfaceMesh, term: &mut dyn ForceTerm, options: FdOptions) -> f64 {
    let mut membrane = Membrane::from_mesh(mesh, true).unwrap();
    // Control points near the rim and above the centre.
    membrane.add_control_point(ControlPoint {
        position: DVec3::new(4.5, 0.3, 0.5),
        stiffness: 4.0,
    });
    membrane.add_control_point(ControlPoint {
        position: DVec3::new(0.2, -0.1, 5.0),
        stiffness: 2.5,
    });
    let t = membrane.topology().unwrap().clone();
    assert!(t.is_open());
    let mut pos = Vec::new();
    membrane.gather_positions(&mut pos);
    let rho: Vec<f64> = (0..pos.len())
        .map(|i| 0.8 + 0.4 * ((i * 7919) % 101) as f64 / 100.0)
        .collect();
    let report = check_force_term(term, &membrane.world, &t, &pos, &rho, None, options);
    println!(
        "{name} ({} vertices): max rel err {:.2e}, max abs err {:.2e}, max |F| {:.3e}",
        pos.len(),
        report.max_rel_error,
        report.max_abs_error,
        report.max_force
    );
    assert!(report.max_force > 1e-3, "{name}: forces too small");
    assert!(
        report.passed(),
        "{name}: {} vertices fail, first {:?}",
        report.failures.len(),
        report.failures[0]
    );
    report.max_rel_error
}

#[test]
fn bending_on_open_patches() {
    for seed in [1, 2] {
        for (mesh, shape) in perturbed_patches(seed).iter().zip(["cap", "disc"]) {
            // |K| is not differentiable at 0, where a nearly flat disc has
            // many vertices: c0 ≠ 0 (whose energy has the kink) on the cap.
            let c0s: &[f64] = if shape == "cap" { &[0.0, 0.3] } else { &[0.0] };
            for &c0 in c0s {
                let mut term = BendingForces::new(BendingParams {
                    kappa: 5.0,
                    c0,
                    ..Default::default()
                });
                // As on the sphere: a step of 1e-5 resolves |K|'s kink
                // where c0 ≠ 0.
                let options = FdOptions {
                    step: 1e-5,
                    ..opts(1e-9)
                };
                check(
                    &format!("bending {shape} c0 {c0}"),
                    mesh,
                    &mut term,
                    options,
                );
            }
            // The dihedral form's signed h has no kink: c0 ≠ 0 on both.
            for c0 in [0.0, 0.3] {
                let mut term = BendingForces::new(BendingParams {
                    kappa: 5.0,
                    c0,
                    discretisation: BendingDiscretisation::Dihedral,
                });
                check(
                    &format!("bending dihedral {shape} c0 {c0}"),
                    mesh,
                    &mut term,
                    opts(1e-9),
                );
            }
        }
    }
}

#[test]
fn area_tension_and_local_tension_on_open_patches() {
    for (mesh, shape) in perturbed_patches(3).iter().zip(["cap", "disc"]) {
        let a = total_area(&mesh.positions, &mesh.faces);
        let mut area = AreaForces::new(8.0, 1.05 * a);
        check(&format!("area {shape}"), mesh, &mut area, opts(1e-8));
        let mut tension = TensionForces::new(0.125);
        check(&format!("tension {shape}"), mesh, &mut tension, opts(1e-8));
        let a0 = a / mesh.vertex_count() as f64;
        let mut local = LocalTensionForces::new(12.0, 1.1 * a0);
        check(
            &format!("local tension {shape}"),
            mesh,
            &mut local,
            opts(1e-9),
        );
    }
}

#[test]
fn vin_springs_and_self_avoidance_on_open_patches() {
    let seg = Arc::new(Segmentation::new(VinParams::default()));
    for (mesh, shape) in perturbed_patches(4).iter().zip(["cap", "disc"]) {
        let mut vin = VinForces::new(seg.clone(), VinForm::Exact);
        check(&format!("vin exact {shape}"), mesh, &mut vin, opts(1e-9));
        let mut linear = VinForces::new(seg.clone(), VinForm::PiecewiseLinear);
        let options = FdOptions {
            step: 1e-7,
            stencil: Stencil::Central2,
            rel_tol: 1e-6,
            abs_floor: 1e-7,
        };
        check(&format!("vin linear {shape}"), mesh, &mut linear, options);
        for coupling in [
            SpringCoupling::OneRing,
            SpringCoupling::Centroid,
            SpringCoupling::Gaussian { radius: 1.2 },
        ] {
            let mut springs = SpringForces::new(coupling);
            check(
                &format!("springs {coupling:?} {shape}"),
                mesh,
                &mut springs,
                opts(1e-9),
            );
        }
        let mut avoid = SelfAvoidanceForces::new(remembrane::params::SelfAvoidanceParams {
            k: 20.0,
            distance: 1.9,
        });
        check(
            &format!("self avoidance {shape}"),
            mesh,
            &mut avoid,
            opts(1e-9),
        );
    }
}

#[test]
fn wall_and_adhesion_on_open_patches() {
    // A plane just below the disc's and the cap's rims, within range of
    // their lowest vertices.
    for (mesh, shape) in perturbed_patches(5).iter().zip(["cap", "disc"]) {
        let low = mesh
            .positions
            .iter()
            .map(|p| p.z)
            .fold(f64::INFINITY, f64::min);
        let plane = WallShape::Plane {
            point: (0.0, 0.0, low - 0.2),
            normal: (0.0, 0.0, 1.0),
        };
        let mut wall = WallForces::new(WallParams {
            shape: plane,
            strength: 1.0,
            range: 0.5,
            name: "wall".into(),
        });
        check(&format!("wall {shape}"), mesh, &mut wall, opts(1e-9));
        let mut adhesion = AdhesionForces::new(AdhesionParams {
            shape: plane,
            strength: 0.5,
            range: 0.6,
            name: "adhesion".into(),
        });
        check(
            &format!("adhesion {shape}"),
            mesh,
            &mut adhesion,
            opts(1e-9),
        );
    }
}

#[test]
fn volume_above_a_closing_plane_on_open_patches() {
    use remembrane::energy::penalty::volume_above_plane;
    use remembrane::energy::volume::VolumeForces;
    // A tilted plane below the patches, and one through them.
    let planes = [
        (
            DVec3::new(0.3, -0.2, -1.5),
            DVec3::new(0.1, -0.2, 1.0).normalize(),
        ),
        (DVec3::new(0.0, 0.0, 0.4), DVec3::Z),
    ];
    for (mesh, shape) in perturbed_patches(5).iter().zip(["cap", "disc"]) {
        for (k, &(point, normal)) in planes.iter().enumerate() {
            let v = volume_above_plane(&mesh.positions, &mesh.faces, point, normal);
            let mut term = VolumeForces::closed_by_plane(4.0, 0.7 * v.abs() + 1.0, point, normal);
            check(
                &format!("volume {shape} plane {k}"),
                mesh,
                &mut term,
                opts(1e-8),
            );
        }
    }
    // On a closed membrane it is the enclosed volume, whatever the plane.
    let sphere = remembrane::fd::perturbed_icosphere(2, 9);
    let enclosed =
        remembrane::mesh::geometry::enclosed_volume(&sphere.positions, &sphere.faces, DVec3::ZERO);
    for &(point, normal) in &planes {
        let v = volume_above_plane(&sphere.positions, &sphere.faces, point, normal);
        assert!((v - enclosed).abs() < 1e-12 * enclosed, "{v} vs {enclosed}");
    }
    // A flat disc h = 0.25 above the plane holds A h.
    let disc = remembrane::mesh::disc(3.0, 0.5);
    let area = total_area(&disc.positions, &disc.faces);
    let v = volume_above_plane(
        &disc.positions,
        &disc.faces,
        DVec3::new(0.0, 0.0, -0.25),
        DVec3::Z,
    );
    assert!(
        (v - 0.25 * area).abs() < 1e-12 * area,
        "{v} vs {}",
        0.25 * area
    );
}
