//! Scheduled control-point changes are pure scene data and act on the run.

use glam::DVec3;
use remembrane::mesh::components::{ControlPoint, ControlPointIndex};
use remembrane::scene::Scene;
use std::path::Path;

const SCENE: &str = r#"Scene(
    name: "pull",
    membrane: Icosphere(level: 2),
    energy: [Vin(), Bending(kappa: 1.0), Springs(stiffness: 4.0)],
    control_points: [
        (position: (3.6, 0.0, 0.0)),
        (position: (-3.34, 0.0, 0.0), stiffness: 2.0),
        (position: (0.0, 3.34, 0.0)),
    ],
    control_point_schedule: [
        (when: Every(interval: 10, start: 10), points: [0], change: MoveBy(0.1, 0.0, 0.0)),
        (when: At(iteration: 25), points: [1, 2], change: ScaleAbout(center: (0.0, 0.0, 0.0), factor: 1.2)),
        (when: At(iteration: 30), points: [1], change: SetStiffness(7.0)),
    ],
    dynamics: (iterations: 100),
)"#;

fn points(sim: &remembrane::engine::simulation::Simulation) -> Vec<ControlPoint> {
    let mut v: Vec<(u32, ControlPoint)> = sim
        .membrane()
        .world
        .query::<(&ControlPointIndex, &ControlPoint)>()
        .iter()
        .map(|(i, p)| (i.0, *p))
        .collect();
    v.sort_by_key(|(i, _)| *i);
    v.into_iter().map(|(_, p)| p).collect()
}

#[test]
fn schedules_move_scale_and_restiffen_points_when_due() {
    let path = Path::new("pull.ron");
    let mut sim = Scene::from_ron_str(SCENE, path)
        .unwrap()
        .build(path)
        .unwrap();
    let mut history = Vec::new();
    for _ in 0..60 {
        sim.tick().unwrap();
        history.push((sim.clock().iteration, points(&sim)));
    }
    let at = |n: u64| &history.iter().find(|(i, _)| *i == n).unwrap().1;
    // Every 10 from 10: applied before iterations 11, 21, 31, 41, 51.
    assert!((at(10)[0].position.x - 3.6).abs() < 1e-12);
    assert!((at(11)[0].position.x - 3.7).abs() < 1e-12);
    assert!((at(60)[0].position.x - 4.1).abs() < 1e-12);
    // Scaled once by 1.2 after 25 iterations.
    assert!((at(25)[2].position.y - 3.34).abs() < 1e-12);
    assert!((at(26)[2].position.y - 3.34 * 1.2).abs() < 1e-12);
    assert!((at(60)[2].position.y - 3.34 * 1.2).abs() < 1e-12);
    assert!((at(60)[1].position.x + 3.34 * 1.2).abs() < 1e-12);
    assert_eq!(at(30)[1].stiffness, 2.0);
    assert_eq!(at(31)[1].stiffness, 7.0);
    assert_eq!(at(60)[0].stiffness, 4.0);
}

#[test]
fn the_membrane_follows_a_moved_control_point() {
    let path = Path::new("pull.ron");
    let mut sim = Scene::from_ron_str(SCENE, path)
        .unwrap()
        .build(path)
        .unwrap();
    let x_max = |sim: &remembrane::engine::simulation::Simulation| {
        sim.positions()
            .iter()
            .map(|p: &DVec3| p.x)
            .fold(f64::MIN, f64::max)
    };
    sim.tick().unwrap();
    let start = x_max(&sim);
    for _ in 0..99 {
        sim.tick().unwrap();
    }
    assert!(
        x_max(&sim) > start + 0.2,
        "tip at {} from {start}",
        x_max(&sim)
    );
}

#[test]
fn a_schedule_naming_a_missing_point_is_rejected() {
    let text = SCENE.replace("points: [1, 2]", "points: [1, 5]");
    let err = Scene::from_ron_str(&text, Path::new("pull.ron"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("control_point_schedule[1].points") && err.contains("point 5"),
        "{err}"
    );
    let text = SCENE.replace("interval: 10", "interval: 0");
    let err = Scene::from_ron_str(&text, Path::new("pull.ron"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("control_point_schedule[0].when"), "{err}");
}

/// The centroid coupling is the as-run coupling without its squeeze: on a
/// perturbed mesh both exert the same net force on the attached patch, and
/// their energies differ by exactly ½k Σ_j |x_j − x̄|² (parallel-axis
/// theorem), the term that compresses the ring around each control point.
#[test]
fn centroid_coupling_keeps_the_net_pull_and_drops_the_squeeze() {
    use remembrane::energy::springs::{control_point_springs, nearest_vertex};
    use remembrane::params::SpringCoupling;
    let mut mesh = remembrane::mesh::icosphere(3, 1.0);
    mesh.jitter(0.1, 5);
    let mut membrane = remembrane::mesh::membrane::Membrane::from_mesh(&mesh, false).unwrap();
    let t = membrane.topology().unwrap().clone();
    let point = ControlPoint {
        position: DVec3::new(8.0, 2.0, -1.0),
        stiffness: 4.0,
    };
    let run = |coupling| {
        let mut force = vec![DVec3::ZERO; mesh.positions.len()];
        let energy = control_point_springs(
            &mesh.positions,
            &t,
            &[point],
            &[nearest_vertex(&mesh.positions, point.position)],
            coupling,
            Some(&mut force),
        );
        (energy, force)
    };
    let (e_ring, f_ring) = run(SpringCoupling::OneRing);
    let (e_centroid, f_centroid) = run(SpringCoupling::Centroid);
    let i = nearest_vertex(&mesh.positions, point.position);
    let patch: Vec<usize> = std::iter::once(i)
        .chain(t.neighbours(i).iter().map(|&j| j as usize))
        .collect();
    let centroid = patch.iter().map(|&j| mesh.positions[j]).sum::<DVec3>() / patch.len() as f64;
    let squeeze: f64 = patch
        .iter()
        .map(|&j| 0.5 * point.stiffness * mesh.positions[j].distance_squared(centroid))
        .sum();
    assert!(squeeze > 0.1, "the test patch has a squeeze term");
    assert!(
        (e_ring - e_centroid - squeeze).abs() < 1e-10 * e_ring,
        "{e_ring} − {e_centroid} ≠ {squeeze}"
    );
    let net = |f: &[DVec3]| f.iter().sum::<DVec3>();
    assert!(net(&f_ring).distance(net(&f_centroid)) < 1e-10 * net(&f_ring).length());
    // The squeeze is gone: every patch vertex feels the same pull.
    for &j in &patch {
        assert!(f_centroid[j].distance(f_centroid[i]) < 1e-12);
    }
}
