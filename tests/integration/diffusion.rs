//! Lipid diffusion: Σρ conserved to 1e-12 (alone and with remeshing),
//! barriers pass density only through permitted edges, k_d = ∞ and long
//! finite diffusion give uniform ρ.

use glam::DVec3;
use remembrane::diffusion::{blocked, diffuse};
use remembrane::engine::shared_resources::RemeshTriggered;
use remembrane::mesh::components::LipidDensity;
use remembrane::mesh::icosphere;
use remembrane::mesh::membrane::Membrane;
use remembrane::params::BlockedRegion;
use remembrane::remesh::RemeshStats;
use remembrane::scene::Scene;
use std::path::Path;

fn sphere() -> (Vec<DVec3>, remembrane::mesh::topology::Topology) {
    let mesh = icosphere(3, 1.0);
    let mut m = Membrane::from_mesh(&mesh, true).unwrap();
    let t = m.topology().unwrap().clone();
    (mesh.positions, t)
}

fn sum(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s.iter().sum()
}

#[test]
fn diffusion_conserves_density_and_equilibrates() {
    let (_, t) = sphere();
    let mut rho: Vec<f64> = (0..t.vertex_count())
        .map(|i| 0.5 + ((i * 37) % 11) as f64 / 10.0)
        .collect();
    let total = sum(&rho);
    let mut scratch = Vec::new();
    diffuse(
        &mut rho,
        &t.edges,
        |v| t.valence(v),
        |_| true,
        0.1,
        50,
        &mut scratch,
    );
    assert!((sum(&rho) - total).abs() < 1e-12 * total);
    for _ in 0..200 {
        diffuse(
            &mut rho,
            &t.edges,
            |v| t.valence(v),
            |_| true,
            0.1,
            50,
            &mut scratch,
        );
    }
    assert!((sum(&rho) - total).abs() < 1e-12 * total);
    let mean = total / rho.len() as f64;
    // Eq. 11 conserves Σρ; its fixed point has ρ_i ∝ valence_i.
    let weights: f64 = (0..rho.len()).map(|v| t.valence(v) as f64).sum();
    for (v, r) in rho.iter().enumerate() {
        let expected = total * t.valence(v) as f64 / weights;
        // Converged to 1e-8 after 10^4 sweeps (the slowest mode decays slowly).
        assert!(
            (r - expected).abs() < 1e-6 * mean,
            "vertex {v}: {r} vs {expected}"
        );
    }
}

#[test]
fn a_barrier_passes_density_only_through_permitted_edges() {
    let (pos, t) = sphere();
    let right: Vec<bool> = pos.iter().map(|p| p.x > 1.5).collect();
    let start: Vec<f64> = right.iter().map(|&r| if r { 2.0 } else { 0.0 }).collect();
    let mut scratch = Vec::new();
    // Fully closed slab: nothing crosses, blocked vertices never change.
    let closed = [BlockedRegion::Slab {
        half_width: 1.5,
        gap: 0.0,
    }];
    let free: Vec<bool> = pos.iter().map(|&p| !blocked(&closed, p)).collect();
    assert!(free.iter().filter(|f| !**f).count() > 50);
    let mut rho = start.clone();
    diffuse(
        &mut rho,
        &t.edges,
        |v| t.valence(v),
        |v| free[v],
        0.2,
        500,
        &mut scratch,
    );
    for v in 0..rho.len() {
        if !free[v] || pos[v].x < -1.5 {
            assert_eq!(rho[v], start[v], "vertex {v} at x = {} changed", pos[v].x);
        }
    }
    // The paper's barrier (gap 0.1): density crosses, only through vertices
    // near y = 0 that stay permeable.
    let gapped = [BlockedRegion::Slab {
        half_width: 1.5,
        gap: 0.1,
    }];
    let free: Vec<bool> = pos.iter().map(|&p| !blocked(&gapped, p)).collect();
    let slab_free: Vec<usize> = (0..pos.len())
        .filter(|&v| pos[v].x.abs() < 1.5 && free[v])
        .collect();
    assert!(!slab_free.is_empty());
    assert!(
        slab_free
            .iter()
            .all(|&v| pos[v].y.abs() <= 0.1 * pos[v].length())
    );
    let mut rho = start.clone();
    diffuse(
        &mut rho,
        &t.edges,
        |v| t.valence(v),
        |v| free[v],
        0.2,
        2000,
        &mut scratch,
    );
    let left: f64 = (0..rho.len())
        .filter(|&v| pos[v].x < -1.5)
        .map(|v| rho[v])
        .sum();
    assert!(left > 0.01, "density reached the far side: {left}");
    assert!((sum(&rho) - sum(&start)).abs() < 1e-12 * sum(&start));
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn instant_diffusion_and_remeshing_conserve_density() {
    let path = crate::common::repo("scenes/red_blood_cell_stiff.ron");
    for rate in ["Instant", "Finite(0.1)"] {
        let text = std::fs::read_to_string(&path).unwrap().replace(
            "    penalty_smoothing: 4,",
            &format!("    penalty_smoothing: 4,\n    lipid_density: true,\n    diffusion: (rate: {rate}, sweeps: 50),"),
        );
        let scene = Scene::from_ron_str(&text, &path).unwrap();
        let mut sim = scene.build(&path).unwrap();
        let density = |sim: &remembrane::engine::simulation::Simulation| -> Vec<f64> {
            sim.membrane()
                .world
                .query::<&LipidDensity>()
                .iter()
                .map(|d| d.0)
                .collect()
        };
        let total = sum(&density(&sim));
        let mut diffused = 0;
        for _ in 0..1500 {
            sim.tick().unwrap();
            if sim.resource::<RemeshTriggered>().0 {
                diffused += 1;
                let rho = density(&sim);
                assert!((sum(&rho) - total).abs() < 1e-12 * total, "{rate}");
                if rate == "Instant" {
                    let mean = total / rho.len() as f64;
                    let worst = rho.iter().map(|r| (r - mean).abs()).fold(0.0, f64::max);
                    assert!(
                        worst < 1e-12 * mean,
                        "iteration {}: deviation {worst}",
                        sim.clock().iteration
                    );
                }
            }
        }
        assert!(diffused > 10, "{rate}: diffusion ran {diffused} times");
        assert!(sim.resource::<RemeshStats>().successes() > 10);
    }
}

#[test]
fn diffusion_needs_lipid_density_and_remeshing() {
    let text = r#"Scene(membrane: Icosphere(level: 2), energy: [Vin()], remesh: (mode: FreeEnergy),
        diffusion: (rate: Finite(0.1)))"#;
    let err = Scene::from_ron_str(text, Path::new("d.ron"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("lipid_density"), "{err}");
    let text = text
        .replace("energy:", "lipid_density: true, energy:")
        .replace("Finite(0.1)", "Finite(1.5)");
    let err = Scene::from_ron_str(&text, Path::new("d.ron"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("diffusion.rate"), "{err}");
}
