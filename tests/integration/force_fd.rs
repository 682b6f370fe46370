//! Every energy term's analytic force equals minus the finite-difference
//! gradient of its energy on randomly perturbed 162- and 642-vertex
//! icospheres (relative error ≤ 1e-6 per vertex force vector, absolute floor
//! stated per test: the round-off level of the difference quotient).

use glam::DVec3;
use remembrane::energy::vin::{Segmentation, VinForm, VinParams};
use remembrane::energy::{
    area::AreaForces, bending::BendingForces, local_tension::LocalTensionForces,
    self_avoidance::SelfAvoidanceForces, springs::SpringForces, tension::TensionForces,
    vin::VinForces, volume::VolumeForces,
};
use remembrane::engine::force::ForceTerm;
use remembrane::fd::{FdOptions, Stencil, check_force_term};
use remembrane::mesh::SurfaceMesh;
use remembrane::mesh::components::ControlPoint;
use remembrane::mesh::membrane::Membrane;
use remembrane::params::{BendingDiscretisation, BendingParams, SpringCoupling};
use std::sync::Arc;

/// Relative tolerance on the per-vertex force vector.
const REL_TOL: f64 = 1e-6;

/// The perturbed icosphere every term is checked on.
fn perturbed(level: u32, seed: u64) -> SurfaceMesh {
    remembrane::fd::perturbed_icosphere(level, seed)
}

fn check(
    name: &str,
    mesh: &SurfaceMesh,
    term: &mut dyn ForceTerm,
    lipid: bool,
    options: FdOptions,
) {
    let mut membrane = Membrane::from_mesh(mesh, lipid).unwrap();
    membrane.add_control_point(ControlPoint {
        position: DVec3::new(9.0, 1.0, 0.5),
        stiffness: 4.0,
    });
    membrane.add_control_point(ControlPoint {
        position: DVec3::new(-2.0, -8.0, 1.0),
        stiffness: 2.5,
    });
    membrane.topology().unwrap();
    let (mut pos, mut rho) = (Vec::new(), Vec::new());
    membrane.gather_positions(&mut pos);
    if lipid {
        // Non-uniform density so the local-tension test is not trivial.
        rho = (0..pos.len())
            .map(|i| 0.8 + 0.4 * ((i * 7919) % 101) as f64 / 100.0)
            .collect();
    }
    let report = check_force_term(
        term,
        &membrane.world,
        membrane.cached_topology(),
        &pos,
        &rho,
        None,
        options,
    );
    println!(
        "{name} ({} vertices): max rel err {:.2e}, max abs err {:.2e}, max |F| {:.3e}",
        pos.len(),
        report.max_rel_error,
        report.max_abs_error,
        report.max_force
    );
    assert!(
        report.max_force > 1e-3,
        "{name}: forces too small to test anything"
    );
    assert!(
        report.passed(),
        "{name}: {} vertices fail, first {:?}",
        report.failures.len(),
        report.failures[0]
    );
}

fn opts(abs_floor: f64) -> FdOptions {
    FdOptions {
        rel_tol: REL_TOL,
        abs_floor,
        ..FdOptions::default()
    }
}

#[test]
fn bending_force_matches_finite_differences() {
    for (level, seed) in [(2, 11), (3, 12)] {
        let mesh = perturbed(level, seed);
        let mut term = BendingForces::new(BendingParams {
            kappa: 1.0,
            c0: 0.0,
            ..Default::default()
        });
        check("bending", &mesh, &mut term, false, opts(1e-9));
    }
}

#[test]
fn dihedral_bending_force_matches_finite_differences() {
    for (level, seed, c0) in [(2, 31, 0.0), (3, 32, 0.0), (2, 33, 0.4), (3, 34, -0.3)] {
        let mesh = perturbed(level, seed);
        let mut term = BendingForces::new(BendingParams {
            kappa: 5.0,
            c0,
            discretisation: BendingDiscretisation::Dihedral,
        });
        check("bending dihedral", &mesh, &mut term, false, opts(1e-9));
    }
}

#[test]
fn bending_with_spontaneous_curvature_matches_finite_differences() {
    for (level, seed) in [(2, 21), (3, 22)] {
        let mesh = perturbed(level, seed);
        let mut term = BendingForces::new(BendingParams {
            kappa: 5.0,
            c0: 0.4,
            ..Default::default()
        });
        // |K_i| is not differentiable at 0 and the rough test mesh has
        // vertices with |K| ≈ 3e-3: a step of 1e-4 spans the kink there (rel.
        // error 3e-4), 1e-5 resolves it (3.5e-8).
        let options = FdOptions {
            step: 1e-5,
            ..opts(1e-9)
        };
        check("bending c0", &mesh, &mut term, false, options);
    }
}

#[test]
fn exact_vin_force_matches_finite_differences() {
    let seg = Arc::new(Segmentation::new(VinParams::default()));
    for (level, seed) in [(2, 31), (3, 32)] {
        let mesh = perturbed(level, seed);
        let mut term = VinForces::new(seg.clone(), VinForm::Exact);
        check("vin exact", &mesh, &mut term, false, opts(1e-9));
    }
}

#[test]
fn piecewise_linear_vin_force_matches_finite_differences() {
    // The piecewise-linear energy is exactly linear within a segment: a
    // second-order stencil with a step far below the narrowest segment
    // (1.4e-3 l̄) is exact up to round-off (≈ ε·E_in/h ≈ 1e-9).
    let seg = Arc::new(Segmentation::new(VinParams::default()));
    for (level, seed) in [(2, 41), (3, 42)] {
        let mesh = perturbed(level, seed);
        let mut term = VinForces::new(seg.clone(), VinForm::PiecewiseLinear);
        let options = FdOptions {
            step: 1e-7,
            stencil: Stencil::Central2,
            rel_tol: REL_TOL,
            abs_floor: 1e-7,
        };
        check("vin linear", &mesh, &mut term, false, options);
    }
}

#[test]
fn volume_force_matches_finite_differences() {
    for (level, seed) in [(2, 51), (3, 52)] {
        let mesh = perturbed(level, seed);
        let v0 =
            remembrane::mesh::geometry::enclosed_volume(&mesh.positions, &mesh.faces, DVec3::ZERO);
        let mut term = VolumeForces::new(4.0, 0.6 * v0);
        check("volume", &mesh, &mut term, false, opts(1e-8));
    }
}

#[test]
fn area_force_matches_finite_differences() {
    for (level, seed) in [(2, 61), (3, 62)] {
        let mesh = perturbed(level, seed);
        let a0 = remembrane::mesh::geometry::total_area(&mesh.positions, &mesh.faces);
        let mut term = AreaForces::new(8.0, 1.05 * a0);
        check("area", &mesh, &mut term, false, opts(1e-8));
    }
}

#[test]
fn tension_force_matches_finite_differences() {
    for (level, seed) in [(2, 65), (3, 66)] {
        let mesh = perturbed(level, seed);
        let mut term = TensionForces::new(0.125);
        check("tension", &mesh, &mut term, false, opts(1e-8));
    }
}

#[test]
fn local_tension_force_matches_finite_differences() {
    for (level, seed) in [(2, 71), (3, 72)] {
        let mesh = perturbed(level, seed);
        let a0 = remembrane::mesh::geometry::total_area(&mesh.positions, &mesh.faces)
            / mesh.vertex_count() as f64;
        let mut term = LocalTensionForces::new(12.0, 1.1 * a0);
        check("local tension", &mesh, &mut term, true, opts(1e-9));
    }
}

#[test]
fn spring_force_matches_finite_differences() {
    for (level, seed) in [(2, 81), (3, 82)] {
        let mesh = perturbed(level, seed);
        for coupling in [
            SpringCoupling::OneRing,
            SpringCoupling::Centroid,
            SpringCoupling::Gaussian { radius: 1.2 },
        ] {
            let mut term = SpringForces::new(coupling);
            check(
                &format!("springs ({coupling:?})"),
                &mesh,
                &mut term,
                false,
                opts(1e-9),
            );
        }
    }
}

#[test]
fn self_avoidance_force_matches_finite_differences() {
    // A range of 1.9 l̄ reaches the 2-ring of a unit-edge mesh, so many
    // pairs repel on the perturbed sphere.
    for (level, seed) in [(2, 61), (3, 62)] {
        let mesh = perturbed(level, seed);
        let mut term = SelfAvoidanceForces::new(remembrane::params::SelfAvoidanceParams {
            k: 20.0,
            distance: 1.9,
        });
        check("self_avoidance", &mesh, &mut term, false, opts(1e-9));
    }
}
