//! Protein species in overdamped dynamics: a field's transport relaxes at
//! the continuum's rate, and at temperature its fluctuations are those of
//! ideal mixing.

use remembrane::engine::simulation::Simulation;
use remembrane::scene::Scene;
use remembrane::species::model::SpeciesModel;
use remembrane::species::state::{SpeciesAmounts, fractions_at, write_fractions};

/// A scene whose shape holds still (vertex mobility 1e-9 l̄²/(Ē·s)) under
/// one species declared by `species`, run in ticks of `dt_max`.
fn frozen(membrane: &str, species: &str, dt_max: f64, temperature: f64) -> Simulation {
    let text = format!(
        r#"Scene(
    name: "frozen",
    membrane: {membrane},
    energy: [Bending(kappa: 1.0)],
    dynamics: (mobility: 1e-9, temperature: {temperature}, dt_max: {dt_max}, frames: 0),
    species: (species: [{species}], temperature: 0.1),
)"#
    );
    let path = std::path::Path::new("frozen.ron");
    Scene::from_ron_str(&text, path)
        .unwrap()
        .build(path)
        .unwrap()
}

/// The positions and the species' fractions now.
fn fields(sim: &mut Simulation) -> (Vec<glam::DVec3>, Vec<f64>, Vec<f64>) {
    let (set, form) = {
        let m = sim.resource::<SpeciesModel>();
        (m.set.clone(), m.base.discretisation)
    };
    let membrane = sim.membrane_mut();
    let t = membrane.topology().unwrap().clone();
    let mut positions = Vec::new();
    membrane.gather_positions(&mut positions);
    let mut amounts = SpeciesAmounts::default();
    amounts.gather(&membrane.world, &t, 1);
    let phi = fractions_at(&set, &amounts.0, &positions, &t.faces, form);
    let mut geometry = Vec::new();
    remembrane::mesh::geometry::face_geometry(&positions, &t.faces, &mut geometry);
    let areas =
        remembrane::species::surface::vertex_areas(&t.faces, &geometry, positions.len(), form);
    (positions, phi[0].clone(), areas)
}

/// The Legendre polynomial P_l(x), l ≤ 4.
fn legendre(l: u32, x: f64) -> f64 {
    match l {
        2 => 0.5 * (3.0 * x * x - 1.0),
        4 => (35.0 * x.powi(4) - 30.0 * x * x + 3.0) / 8.0,
        _ => unreachable!(),
    }
}

#[test]
fn a_dilute_field_on_a_sphere_relaxes_at_the_diffusion_rate_of_each_mode() {
    // D = M k_BT / a_p = 0.1 · 0.1 / 0.01 = 1 l̄²/s on a sphere of R = 4.
    let (radius, d) = (4.0, 1.0);
    for l in [2u32, 4] {
        let rate = d * f64::from(l * (l + 1)) / (radius * radius);
        let dt = 0.02 / rate;
        let mut sim = frozen(
            "Ellipsoid(level: 4, semi_axes: (4.0, 4.0, 4.0))",
            "(name: \"p\", area_per_protein: 0.01, initial: Fraction(0.01), mobility: 0.1)",
            dt,
            0.0,
        );
        let (positions, _, _) = fields(&mut sim);
        let shape: Vec<f64> = positions
            .iter()
            .map(|p| legendre(l, p.z / p.length()))
            .collect();
        let phi: Vec<f64> = shape.iter().map(|y| 0.01 * (1.0 + 0.01 * y)).collect();
        let (set, form) = {
            let m = sim.resource::<SpeciesModel>();
            (m.set.clone(), m.base.discretisation)
        };
        write_fractions(sim.membrane_mut(), &set, form, 0, &phi).unwrap();
        // The mode's amplitude against time, from e^{-1/2} to e^{-2} of it.
        let (mut ts, mut logs) = (Vec::new(), Vec::new());
        for tick in 1..=100 {
            sim.tick().unwrap();
            let (_, phi, areas) = fields(&mut sim);
            let mean =
                phi.iter().zip(&areas).map(|(p, a)| p * a).sum::<f64>() / areas.iter().sum::<f64>();
            let amplitude = (0..phi.len())
                .map(|i| areas[i] * (phi[i] - mean) * shape[i])
                .sum::<f64>()
                / (0..phi.len())
                    .map(|i| areas[i] * shape[i] * shape[i])
                    .sum::<f64>();
            if tick >= 25 {
                ts.push(sim.clock().time);
                logs.push(amplitude.ln());
            }
        }
        let n = ts.len() as f64;
        let (mt, ml) = (ts.iter().sum::<f64>() / n, logs.iter().sum::<f64>() / n);
        let slope = ts
            .iter()
            .zip(&logs)
            .map(|(t, y)| (t - mt) * (y - ml))
            .sum::<f64>()
            / ts.iter().map(|t| (t - mt) * (t - mt)).sum::<f64>();
        let measured = -slope;
        eprintln!(
            "l = {l}: rate {measured:.6} against D l(l+1)/R² = {rate:.6} ({:+.3} %)",
            100.0 * (measured / rate - 1.0)
        );
        assert!((measured / rate - 1.0).abs() < 0.02, "l = {l}");
    }
}

#[test]
fn at_temperature_a_field_fluctuates_as_ideal_mixing_predicts() {
    // About 260 proteins per vertex of the open disc (397 vertices, its rim
    // pinned); D = M k_BT / a_p = 1 l̄²/s.
    let mut sim = frozen(
        "Disc(radius: 10.0, mean_edge_length: 1.0)",
        "(name: \"p\", area_per_protein: 0.001, initial: Fraction(0.3), mobility: 0.01)",
        0.25,
        0.1,
    );
    // Q = Σ_i A_i (φ_i − φ̄)² / (a_p φ̄(1 − φ̄)): a Gaussian field of ideal
    // mixing with the count held gives ⟨Q⟩ = N − 1.
    let q = |sim: &mut Simulation| {
        let (_, phi, areas) = fields(sim);
        let area: f64 = areas.iter().sum();
        let mean = phi.iter().zip(&areas).map(|(p, a)| p * a).sum::<f64>() / area;
        let q = (0..phi.len())
            .map(|i| areas[i] * (phi[i] - mean).powi(2))
            .sum::<f64>()
            / (0.001 * mean * (1.0 - mean));
        q / (phi.len() - 1) as f64
    };
    // The slowest mode relaxes at about D (1.84/R)² = 0.034/s: 100 s first.
    for _ in 0..400 {
        sim.tick().unwrap();
    }
    let (batches, per_batch) = (20, 100);
    let means: Vec<f64> = (0..batches)
        .map(|_| {
            (0..per_batch)
                .map(|_| {
                    sim.tick().unwrap();
                    q(&mut sim)
                })
                .sum::<f64>()
                / per_batch as f64
        })
        .collect();
    let mean = means.iter().sum::<f64>() / batches as f64;
    let error = (means.iter().map(|m| (m - mean).powi(2)).sum::<f64>()
        / (batches * (batches - 1)) as f64)
        .sqrt();
    eprintln!("⟨Q⟩/(N − 1) = {mean:.4} ± {error:.4} (batch means)");
    assert!((mean - 1.0).abs() < 0.05, "{mean} ± {error}");
    assert!(error < 0.01, "{error}");
}
