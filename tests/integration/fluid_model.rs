//! The fluid membrane model (`model: Fluid()`): V_in acts only in the
//! tangent planes. The shear probe (a twisted sphere) measures the shear
//! modulus of the energy that moves the shape in both models; the fluid
//! model's forces, residuals and refusals are checked on real scenes.

use crate::common;
use remembrane::workflow::run::RunOptions;

use glam::DVec3;
use remembrane::energy::vin::{Segmentation, VinParams};
use remembrane::energy::vin_elasticity::network_moduli;
use remembrane::engine::force::ForceKind;
use remembrane::engine::simulation::Simulation;
use remembrane::fluid::vertex_normal;
use remembrane::scene::Scene;
use std::path::Path;

/// A level-4 icosphere (mean edge 1 l̄) with V_in (exact form) and bending,
/// no remeshing, in `model`.
fn twist_scene(model: &str) -> Simulation {
    let text = format!(
        "Scene(name: \"twist\", membrane: Icosphere(level: 4), \
         energy: [Vin(form: Exact), Bending(kappa: 5.0)], remesh: (mode: Off), model: {model})"
    );
    Scene::from_ron_str(&text, Path::new("twist.ron"))
        .unwrap()
        .build(Path::new("twist.ron"))
        .unwrap()
}

/// The sphere's vertices rotated about z by θ(z) = γ z / R: a tangential
/// motion that leaves the sphere a sphere.
fn twisted(p0: &[DVec3], gamma: f64, radius: f64) -> Vec<DVec3> {
    p0.iter()
        .map(|p| {
            let (s, c) = (gamma * p.z / radius).sin_cos();
            DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z)
        })
        .collect()
}

/// At `positions`: the energy of the terms that act on the shape (every
/// term in the paper's model; in the fluid model every term but the
/// mesh-maintenance ones), the total force, and the largest normal
/// component (area-weighted normals) of the force of all terms but
/// bending: V_in's contribution to the shape equation.
fn shape_energy_and_force(
    sim: &mut Simulation,
    positions: &[DVec3],
    fluid: bool,
) -> (f64, Vec<DVec3>, f64) {
    let zero = vec![DVec3::ZERO; positions.len()];
    sim.membrane_mut()
        .scatter_positions_and_forces(positions, &zero);
    let buffers = sim.evaluate_forces().unwrap();
    let energy = buffers
        .terms()
        .iter()
        .zip(&buffers.evaluation.energies)
        .filter(|(t, _)| !(fluid && t.kind == ForceKind::Maintenance))
        .map(|(_, e)| e)
        .sum();
    let bending = buffers.names().iter().position(|n| n == "bending").unwrap();
    let ev = &buffers.evaluation;
    let total = ev.total.clone();
    let bending_force = ev.term_forces[bending].clone();
    drop(buffers);
    let topology = sim.membrane().cached_topology().clone();
    let vin_normal = (0..positions.len())
        .map(|v| {
            let n = vertex_normal(positions, &topology, v);
            (total[v] - bending_force[v]).dot(n).abs()
        })
        .fold(0.0, f64::max);
    (energy, total, vin_normal)
}

/// μ from ΔE = (16π/15) μ γ² R² with ΔE = [E(γ) + E(−γ)]/2 − E(0), the
/// largest change of a normal force component at γ, and the largest
/// normal component of V_in's force at γ.
fn probe(sim: &mut Simulation, p0: &[DVec3], gamma: f64, fluid: bool) -> (f64, f64, f64) {
    let radius = p0.iter().map(|p| p.length()).sum::<f64>() / p0.len() as f64;
    let (e0, f0, _) = shape_energy_and_force(sim, p0, fluid);
    let (ep, fp, vin_normal) = shape_energy_and_force(sim, &twisted(p0, gamma, radius), fluid);
    let (em, _, _) = shape_energy_and_force(sim, &twisted(p0, -gamma, radius), fluid);
    let delta = 0.5 * (ep + em) - e0;
    let mu = 15.0 * delta / (16.0 * std::f64::consts::PI * gamma * gamma * radius * radius);
    // Normal force change, along the area-weighted vertex normals.
    let topology = sim.membrane().cached_topology().clone();
    let tw = twisted(p0, gamma, radius);
    let normal_change = (0..p0.len())
        .map(|v| {
            let n1 = vertex_normal(&tw, &topology, v);
            let n0 = vertex_normal(p0, &topology, v);
            (fp[v].dot(n1) - f0[v].dot(n0)).abs()
        })
        .fold(0.0, f64::max);
    (mu, normal_change, vin_normal)
}

#[test]
fn twisted_sphere_measures_the_shear_modulus_of_each_model() {
    let mut paper = twist_scene("Paper");
    let mut fluid = twist_scene("Fluid()");
    let p0 = paper.membrane_mut().to_mesh().unwrap().positions;
    let topology = paper.membrane().cached_topology().clone();
    let seg = Segmentation::new(VinParams::default());
    let lengths = topology
        .edges
        .iter()
        .map(|&[a, b]| p0[a as usize].distance(p0[b as usize]));
    let predicted = network_moduli(&seg, lengths).shear;
    for gamma in [0.01, 0.02, 0.05] {
        let (mu_paper, dn_paper, vin_paper) = probe(&mut paper, &p0, gamma, false);
        let (mu_fluid, dn_fluid, vin_fluid) = probe(&mut fluid, &p0, gamma, true);
        eprintln!(
            "γ = {gamma}: μ paper {mu_paper:.5} (predicted {predicted:.5}), fluid {mu_fluid:.2e}; \
             normal force change paper {dn_paper:.3e}, fluid {dn_fluid:.3e} (bending's \
             discretisation); V_in's normal force paper {vin_paper:.3e}, fluid {vin_fluid:.1e}"
        );
        assert!(
            (mu_paper / predicted - 1.0).abs() < 0.15,
            "γ = {gamma}: the paper's model measures μ = {mu_paper}, predicted {predicted}"
        );
        assert!(
            mu_fluid.abs() < 0.01 * mu_paper,
            "γ = {gamma}: the fluid model's shape energy has μ = {mu_fluid} (paper {mu_paper})"
        );
        // In the fluid model V_in has no part in the shape equation (to
        // round-off); what still changes the normal forces under the twist
        // is bending's discretisation on the sheared triangles.
        assert!(
            vin_fluid < 1e-12 * vin_paper.max(1e-3),
            "γ = {gamma}: V_in's normal force in the fluid model is {vin_fluid} (paper {vin_paper})"
        );
        assert!(dn_fluid < 0.05 * dn_paper, "{dn_fluid} against {dn_paper}");
    }
}

/// Runs `scene` (read from `path`) quietly into `out`.
fn run(scene: &Scene, path: &Path, out: &Path) -> remembrane::io::summary::RunSummary {
    remembrane::workflow::run::run_scene(scene, path, &RunOptions::quiet(out), |_| Ok(())).unwrap()
}

/// Runs a variant of the fluid red blood cell (scene text `text`, named
/// `name`) and checks that it converged at v = 0.6.
fn converged_cell(text: &str, name: &str) -> remembrane::io::summary::RunSummary {
    let path = Path::new(name);
    let scene = Scene::from_ron_str(text, path).unwrap();
    let out = tempfile::tempdir().unwrap();
    let summary = run(&scene, path, &out.path().join("run"));
    assert!(summary.minimiser.as_ref().unwrap().converged);
    assert!((summary.last.reduced_volume.unwrap() - 0.6).abs() < 1e-4);
    summary
}

/// `text` with `model: Fluid()` parsed and validated as a scene file.
fn fluid_scene_error(extra: &str) -> String {
    let text = format!(
        "Scene(name: \"f\", membrane: Icosphere(level: 2), model: Fluid(), \
         energy: [Vin(), Bending(kappa: 5.0){extra}"
    );
    match Scene::from_ron_str(&text, Path::new("fluid.ron")) {
        Ok(_) => panic!("accepted: {text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn the_fluid_model_refuses_what_it_cannot_do_yet() {
    for (extra, field, hint) in [
        (
            "], dynamics: (temperature: 0.1))",
            "dynamics.temperature",
            "edge_flips",
        ),
        (", LocalTension(k: 1.0)])", "energy[2]", "Tension"),
        (
            "], lipid_density: true, diffusion: (rate: Instant), remesh: (mode: FreeEnergy))",
            "diffusion",
            "paper",
        ),
        (
            ", Springs()], control_points: [(position: (0, 0, 5))])",
            "energy[2]",
            "normal",
        ),
    ] {
        let e = fluid_scene_error(extra);
        assert!(e.contains("fluid.ron"), "{e}");
        assert!(e.contains(field), "{field}: {e}");
        assert!(e.contains(hint), "{hint}: {e}");
    }
}

/// Direct edits (the fluid default) need a gap between the triggers; left
/// out, the fluid model's triggers and relaxation cap fill it (0.6, 1.4,
/// 300), and the paper's event keeps the paper's (0.7, 1.3, 5000).
#[test]
fn direct_edits_take_the_fluid_triggers_and_need_a_gap_between_them() {
    let scene = |model: &str, remesh: &str| {
        let text = format!(
            "Scene(name: \"f\", membrane: Icosphere(level: 2), model: {model}, \
             energy: [Vin(), Bending(kappa: 5.0)], remesh: {remesh})"
        );
        Scene::from_ron_str(&text, Path::new("fluid.ron"))
    };
    // Explicit 0.7 and 1.3: a split's halves (0.65) would merge again.
    for model in ["Fluid()", "Fluid(edits: Direct)"] {
        let e = scene(
            model,
            "(mode: FreeEnergy, shorter_than: 0.7, longer_than: 1.3)",
        )
        .unwrap_err()
        .to_string();
        for part in [
            "fluid.ron",
            "remesh.longer_than",
            "never merged",
            "Fluid(edits: Relaxed)",
        ] {
            assert!(e.contains(part), "{part}: {e}");
        }
    }
    let fluid = scene("Fluid()", "(mode: FreeEnergy)").unwrap();
    let r = fluid.remesh;
    assert_eq!(
        (r.shorter_than, r.longer_than, r.relax_iterations),
        (0.6, 1.4, 300)
    );
    assert!(fluid.model.direct_edits());
    let given = scene(
        "Fluid()",
        "(mode: FreeEnergy, longer_than: 1.5, relax_iterations: 80)",
    )
    .unwrap()
    .remesh;
    assert_eq!(
        (
            given.shorter_than,
            given.longer_than,
            given.relax_iterations
        ),
        (0.6, 1.5, 80)
    );
    let relaxed = scene("Fluid(edits: Relaxed, flips: None)", "(mode: FreeEnergy)")
        .unwrap()
        .remesh;
    assert_eq!(
        (
            relaxed.shorter_than,
            relaxed.longer_than,
            relaxed.relax_iterations
        ),
        (0.7, 1.3, 5000)
    );
    // Without remeshing the edits are moot.
    scene("Fluid(edits: Direct)", "(mode: Off)").unwrap();
    for (flips, field) in [
        ("(max_dihedral: 0.0)", "max_dihedral"),
        ("(max_dihedral: 120.0)", "max_dihedral"),
        ("(every: 0)", "every"),
    ] {
        let text = format!(
            "Scene(name: \"f\", membrane: Icosphere(level: 2), model: Fluid(flips: {flips}), \
             energy: [Vin(), Bending(kappa: 5.0)])"
        );
        let e = Scene::from_ron_str(&text, Path::new("fluid.ron"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("fluid.ron"), "{e}");
        assert!(e.contains(&format!("model.Fluid.flips.{field}")), "{e}");
    }
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn direct_edits_let_a_stretched_fluid_mesh_follow_an_elongation() {
    // The shape diagram's prolate at 2562 vertices (h = 1/2) deflated from
    // its spheroid (v = 0.958) to v = 0.9 stretches the fluid mesh along
    // its axis; with the paper's pre-relaxed events 647 split relaxations
    // failed in the first 90 iterations (benches/RESULTS.md, commit dc9a61c (2026-12-03)).
    // Direct edits (with the scene's maintenance flips): every event
    // succeeds or is impossible (valence), none relaxes first, and no
    // abnormal edge is left.
    let out = tempfile::tempdir().unwrap();
    let path = Path::new("scenes/minimise/shape_diagram/prolate.ron");
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("level: 3,", "level: 4,")
        .replace(
            "valence: (min: 5, max: 8),",
            "valence: (min: 5, max: 8), resolution: EdgeLength(0.5),",
        )
        .replace("Reduced(0.95)", "Reduced(0.9)")
        // The fast deflation of the measurement (the scene now deflates
        // ten times slower, which the walk down to v = 0.55 needs).
        .replace("max_correction: 0.002,", "max_correction: 0.02,")
        // FIRE's slow flow, as measured (the scene now uses the Sobolev
        // minimiser, which reaches v = 0.9 before the mesh stretches).
        .replace("preconditioner: Sobolev(),", "dt_max: 0.2,")
        .replace("every: 10)", "every: 1)");
    assert!(text.contains("EdgeLength(0.5)") && text.contains("edits: Direct"));
    assert!(text.contains("dt_max: 0.2,") && !text.contains("Sobolev()"));
    assert!(text.contains("every: 1)"));
    assert!(text.contains("max_correction: 0.02,"));
    let scene = Scene::from_ron_str(&text, path).unwrap();
    let mut options = RunOptions::quiet(out.path().join("run"));
    options.iterations = Some(600);
    options.check_invariants = Some(true);
    let summary = remembrane::workflow::run::run_scene(&scene, path, &options, |_| Ok(())).unwrap();
    let r = &summary.remesh;
    // Measured: 46 splits, 3 merges and 6 maintenance flips (96 kept by
    // the valence guard).
    assert!(r.split.success > 30, "{r:?}");
    let flips: remembrane::engine::shared_resources::MaintenanceFlipStats =
        summary.section("maintenance_flips").unwrap().unwrap();
    assert!(flips.sweeps == 600 && flips.flipped > 0, "{flips:?}");
    assert_eq!(r.split.failure + r.merge.failure, 0, "{r:?}");
    assert_eq!(r.split.cancel + r.merge.cancel, 0, "{r:?}");
    let pre = &r.relax_iterations;
    assert_eq!(
        pre.pre_success + pre.pre_cancel + pre.pre_failure,
        0,
        "{r:?}"
    );
    assert_eq!(summary.abnormal_edges, 0);
    assert!((summary.last.reduced_volume.unwrap() - 0.9).abs() < 1e-4);
}

/// Edges of the current mesh that are not locally Delaunay although a
/// maintenance flip may take them (valence and dihedral guards).
fn flippable_non_delaunay(sim: &Simulation, max_dihedral: f64) -> usize {
    use remembrane::remesh::flip::Flip;
    use remembrane::remesh::flip::{dihedral, is_non_delaunay};
    let membrane = sim.membrane();
    let mut p = Vec::new();
    membrane.gather_positions(&mut p);
    let t = membrane.cached_topology();
    (0..t.edges.len() as u32)
        .filter_map(|e| Flip::of(t, e))
        .filter(|f| {
            let degree = |v: u32| t.valence(v as usize);
            is_non_delaunay(f, &p)
                && degree(f.a) > 5
                && degree(f.b) > 5
                && degree(f.c) < 8
                && degree(f.d) < 8
                && t.edge_between(f.c, f.d).is_none()
                && dihedral(f, &p) <= max_dihedral.to_radians()
        })
        .count()
}

#[test]
fn maintenance_flips_make_a_jittered_fluid_mesh_delaunay_and_count_it() {
    // A level-3 icosphere, its vertices moved tangentially by up to 0.45
    // edge, stretched into a prolate spheroid (c/a = 2): many edges are
    // not locally Delaunay.
    let text = "Scene(name: \"flips\", seed: 3, \
         membrane: Ellipsoid(level: 3, semi_axes: (4.5, 4.5, 9.0), jitter: 0.45), \
         valence: (min: 5, max: 8), \
         model: Fluid(flips: (max_dihedral: 20.0, every: 1)), \
         energy: [Vin(form: Exact), Bending(kappa: 5.0)], remesh: (mode: Off), \
         dynamics: (method: Minimise(), iterations: 10))";
    let path = Path::new("flips.ron");
    let mut sim = Scene::from_ron_str(text, path)
        .unwrap()
        .build(path)
        .unwrap();
    sim.resource_mut::<remembrane::engine::simulation::CheckInvariants>()
        .0 = true;
    let before = flippable_non_delaunay(&sim, 20.0);
    assert!(before > 20, "the jitter leaves {before} non-Delaunay edges");
    let area = |sim: &Simulation| {
        let membrane = sim.membrane();
        let mut p = Vec::new();
        membrane.gather_positions(&mut p);
        let t = membrane.cached_topology();
        t.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|v| p[v as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum::<f64>()
    };
    let a0 = area(&sim);
    for _ in 0..3 {
        sim.tick().unwrap();
    }
    let after = flippable_non_delaunay(&sim, 20.0);
    let stats = *sim.resource::<remembrane::engine::shared_resources::MaintenanceFlipStats>();
    assert_eq!(stats.sweeps, 3);
    assert!(
        stats.flipped as usize >= before / 2,
        "{stats:?}, {before} before"
    );
    assert_eq!(
        stats.non_delaunay,
        stats.flipped + stats.kept_valence + stats.kept_dihedral + stats.kept_fold,
        "{stats:?}"
    );
    // Three sweeps (the minimiser moving vertices in between) leave almost
    // every edge Delaunay, and the flips barely move the surface.
    assert!(after * 10 <= before, "{after} of {before} left, {stats:?}");
    assert!((area(&sim) / a0 - 1.0).abs() < 0.01);
}

/// A maintenance sweep tests only the edges that were not locally Delaunay
/// at its start and those in quads its flips changed: the same flips, in
/// the same order, as testing every edge in slot order (the sweep before
/// the prefilter), here on a jittered mesh where flips neighbour flips.
#[test]
fn a_maintenance_sweep_flips_what_testing_every_edge_flips() {
    use remembrane::engine::shared_resources::MaintenanceFlipStats;
    use remembrane::mesh::ValenceRange;
    use remembrane::remesh::flip::{Flip, keeps_surface_unfolded};
    use remembrane::remesh::flip::{dihedral, is_non_delaunay};
    let build = |every: u32| {
        let text = format!(
            "Scene(name: \"flips\", seed: 3, \
             membrane: Ellipsoid(level: 3, semi_axes: (4.5, 4.5, 9.0), jitter: 0.45), \
             valence: (min: 5, max: 8), \
             model: Fluid(flips: (max_dihedral: 20.0, every: {every})), \
             energy: [Vin(form: Exact), Bending(kappa: 5.0)], remesh: (mode: Off), \
             dynamics: (method: Minimise(), iterations: 10))"
        );
        let path = Path::new("flips.ron");
        Scene::from_ron_str(&text, path)
            .unwrap()
            .build(path)
            .unwrap()
    };
    // One tick each: the same step, then the system's sweep in one and no
    // sweep in the other (iteration 1 is not a multiple of 1000).
    let (mut swept, mut reference) = (build(1), build(1000));
    swept.tick().unwrap();
    reference.tick().unwrap();
    let membrane = reference.membrane_mut();
    let mut p = Vec::new();
    membrane.gather_positions(&mut p);
    let valence = ValenceRange { min: 5, max: 8 };
    let (mut flipped, mut edge) = (0, 0);
    while edge < membrane.cached_topology().edges.len() {
        let t = membrane.cached_topology();
        let slot = edge as u32;
        edge += 1;
        let Some(flip) = Flip::of(t, slot) else {
            continue;
        };
        let degree = |v: u32| t.valence(v as usize) as u32;
        if !is_non_delaunay(&flip, &p)
            || degree(flip.a) <= valence.min
            || degree(flip.b) <= valence.min
            || degree(flip.c) >= valence.max
            || degree(flip.d) >= valence.max
            || t.edge_between(flip.c, flip.d).is_some()
            || dihedral(&flip, &p) > 20f64.to_radians()
            || !keeps_surface_unfolded(&flip, &p)
        {
            continue;
        }
        let edit = flip.edit(t);
        if membrane.apply_patch(&edit, valence).is_ok() {
            flipped += 1;
        }
    }
    let stats = *swept.resource::<MaintenanceFlipStats>();
    assert!(flipped > 20, "{flipped} flips");
    assert_eq!(stats.flipped, flipped, "{stats:?}");
    assert_eq!(
        swept.membrane().cached_topology().faces,
        reference.membrane().cached_topology().faces
    );
}

#[test]
fn fluid_red_blood_cell_holds_its_constraints_and_reports_its_model() {
    let out = tempfile::tempdir().unwrap();
    let path = Path::new("scenes/fluid/red_blood_cell.ron");
    let summary = run(&Scene::load(path).unwrap(), path, &out.path().join("run"));
    let m = summary.minimiser.as_ref().unwrap();
    assert!(m.converged, "{m:?}");
    assert!((summary.last.reduced_volume.unwrap() - 0.6).abs() < 1e-4);
    assert!((summary.last.area / 553.0 - 1.0).abs() < 1e-4);
    // The continuum at v = 0.6: E_b/8πκ = 1.95568, Δp = -15.667 κ/R0³,
    // σ = -4.700 κ/R0² (axisymmetric solver); measured at 642 vertices:
    // E_b -1.9 %, Δp -2.9 %, σ -4.6 %.
    let kappa = 5.0;
    let r0 = (553.0 / (4.0 * std::f64::consts::PI)).sqrt();
    let eb = common::term_energy(&summary, "bending") / (8.0 * std::f64::consts::PI * kappa);
    assert!((eb / 1.95568 - 1.0).abs() < 0.025, "E_b/8πκ = {eb}");
    let c = summary.constraints.unwrap().reactions;
    let (dp, sigma) = (-15.667 * kappa / r0.powi(3), -4.700 * kappa / r0.powi(2));
    assert!(
        (c.pressure / dp - 1.0).abs() < 0.04,
        "Δp {} vs {dp}",
        c.pressure
    );
    assert!(
        (c.tension / sigma - 1.0).abs() < 0.06,
        "σ {} vs {sigma}",
        c.tension
    );
    let model = &summary.model;
    assert_eq!(model.name, "fluid");
    let r = model.residuals.unwrap();
    assert!(
        r.normal_residual <= m.force_residual * (1.0 + 1e-12),
        "{r:?}"
    );
    assert!(r.net_force < 1e-6, "tangential leak {r:?}");
    assert!(model.vin_moduli.unwrap().shear > 0.0);
    // The paper's model earns the elastic-shell caution; the fluid one not.
    assert!(model.caution.is_none());
    let paper = Path::new("scenes/minimise/red_blood_cell.ron");
    let mut quick = RunOptions::quiet(out.path().join("paper"));
    quick.iterations = Some(5);
    let paper =
        remembrane::workflow::run::run_scene(&Scene::load(paper).unwrap(), paper, &quick, |_| {
            Ok(())
        })
        .unwrap();
    let caution = paper.model.caution.expect("γ > 1 in the paper's model");
    assert!(caution.contains("elastic shell"), "{caution}");
    assert!(paper.model.foppl_von_karman.unwrap() > 1.0);
}

#[test]
fn a_fluid_red_blood_cell_forgets_its_first_triangulation() {
    // The same spheroid triangulated from the icosphere as is and rotated
    // by 45° about x (`tilt`): a fluid has no memory of its first
    // triangulation. Measured at 642 vertices: E_b 241.160 and 241.000
    // (0.066 %), centre thickness 1.758 and 1.769 (0.6 %). The paper's
    // model, an elastic shell, remembers: 241.467 and 241.209 (0.11 %),
    // centre thickness 1.521 and 1.675 (10 %).
    // Measured with FIRE, as recorded above: the bundled scene's Sobolev
    // minimiser ends the two at centre thicknesses 1.758 and 1.800 (2.4 %,
    // also at a force tolerance of 1e-4; E_b 241.172 and 241.217, 0.02 %),
    // an open question of the preconditioned path (benches/RESULTS.md).
    let base = std::fs::read_to_string("scenes/fluid/red_blood_cell.ron")
        .unwrap()
        .replace("preconditioner: Sobolev(),", "");
    let bending = |tilt: f64| {
        let text = base.replace(
            "semi_axes: (6.864, 6.864, 6.178)),",
            &format!("semi_axes: (6.864, 6.864, 6.178), tilt: {tilt}),"),
        );
        assert!(text.contains("tilt"));
        let summary = converged_cell(&text, "tilted.ron");
        (common::term_energy(&summary, "bending"), summary.shape)
    };
    let (e0, s0) = bending(0.0);
    let (e45, s45) = bending(45.0);
    assert!((e45 / e0 - 1.0).abs() < 3e-3, "E_b {e0} and {e45}");
    assert_eq!(s0.class, s45.class);
    assert!(
        (s45.centre_height / s0.centre_height - 1.0).abs() < 0.02,
        "centre thickness {} and {}",
        s0.centre_height,
        s45.centre_height
    );
    // Tilted by 0 the mesh is exactly the untilted one.
    let mut direct = remembrane::mesh::ellipsoid(3, [6.864, 6.864, 6.178], 0.0, 1).positions;
    direct.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
    let mut tilted =
        remembrane::mesh::ellipsoid_tilted(3, [6.864, 6.864, 6.178], 0.0, 0.0, 1).positions;
    tilted.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
    assert_eq!(direct, tilted);
}

#[test]
fn fluid_tether_pulls_along_the_normals_and_reports_what_it_delivers() {
    let out = tempfile::tempdir().unwrap();
    let path = Path::new("scenes/fluid/tether_tube.ron");
    let scene = Scene::load(path).unwrap();
    let dir = out.path().join("run");
    let mut springs_sum = DVec3::ZERO;
    let summary =
        remembrane::workflow::run::run_scene(&scene, path, &RunOptions::quiet(&dir), |_| Ok(()))
            .unwrap();
    assert!(summary.minimiser.as_ref().unwrap().converged);
    // The final state's springs buffer: every vertex force along its
    // normal; the top point's share (z > 0) is what force_top reports.
    let mut opts = RunOptions::quiet(out.path().join("again"));
    opts.from = Some(dir.join("state.json"));
    let mut run = remembrane::workflow::run::prepare_run(&scene, path, &opts).unwrap();
    let sim = &mut run.sim;
    let buffers = sim.evaluate_forces().unwrap();
    let k = buffers.names().iter().position(|n| n == "springs").unwrap();
    let springs = buffers.evaluation.term_forces[k].clone();
    drop(buffers);
    let p = sim.positions();
    let t = sim.membrane().cached_topology().clone();
    for (v, f) in springs.iter().enumerate() {
        let n = vertex_normal(&p, &t, v);
        assert!((*f - f.dot(n) * n).length() < 1e-12, "vertex {v}: {f:?}");
        if p[v].z > 0.0 {
            springs_sum += *f;
        }
    }
    let force_top = *common::series_column(&dir, "force_top").last().unwrap();
    assert!(
        (springs_sum.length() / force_top - 1.0).abs() < 1e-9,
        "force_top {force_top} against the delivered {}",
        springs_sum.length()
    );
    // DJP: r0 = 2.0893, f0 = 3.0073. Measured with the dihedral bending:
    // radius +0.15 %, force -0.39 % (top) and +0.43 % (bottom); the
    // cotangent form read -1.5 %, -9.5 % and -12.6 %.
    let radius = *common::series_column(&dir, "radius_tube").last().unwrap();
    assert!((radius / 2.0893 - 1.0).abs() < 0.01, "radius {radius}");
    let bottom = *common::series_column(&dir, "force_bottom").last().unwrap();
    for f in [force_top, bottom] {
        assert!((f / 3.0073 - 1.0).abs() < 0.01, "force {f}");
    }
}

/// Issue 29's tether: the fluid tube at n = 10, 13, 19 and 25 vertices
/// round (r0 = 1/(2 sin(π/n)) l̄, σ = κ/(2 r0²)), started at 0.8 r0, r0,
/// 1.25 r0 and 1.5 r0, against Derényi-Jülicher-Prost: radius within 1 %,
/// force within 3 % (5 % at n = 10), medians over the second half of the
/// frames, and the tip force's coefficient of variation there below 2 %.
/// Measured (commit 65cd623 (2026-12-04)): radius -0.96..+0.89 % (the starts leave the tube
/// 228-349 vertices at n = 10, 1192-2051 at n = 25, and the coarser mesh
/// reads wider), force -0.51..+0.53 %, CV ≤ 0.25 %.
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn fluid_tethers_from_four_starts_meet_derenyi_julicher_prost() {
    let base = std::fs::read_to_string("scenes/fluid/tether_tube.ron").unwrap();
    let out = tempfile::tempdir().unwrap();
    for n in [10u32, 13, 19, 25] {
        let r0 = 1.0 / (2.0 * (std::f64::consts::PI / n as f64).sin());
        let sigma = 1.0 / (2.0 * r0 * r0);
        let f0 = 2.0 * std::f64::consts::PI * (2.0 * sigma).sqrt();
        let length = 10.0 * r0;
        for start in [0.8, 1.0, 1.25, 1.5] {
            let radius = start * r0;
            let tip = length / 2.0 + radius;
            let text = base
                .replace(
                    "Capsule(radius: 2.0893, length: 20.893,",
                    &format!("Capsule(radius: {radius}, length: {length},"),
                )
                .replace(
                    "Tension(sigma: 0.114544)",
                    &format!("Tension(sigma: {sigma})"),
                )
                .replace("(0.0, 0.0, -12.5357)", &format!("(0.0, 0.0, {})", -tip))
                .replace("(0.0, 0.0, 12.5357)", &format!("(0.0, 0.0, {tip})"))
                .replace(
                    "first: (0.0, 0.0, -3.4822), step: (0.0, 0.0, 0.69643)",
                    &format!(
                        "first: (0.0, 0.0, {}), step: (0.0, 0.0, {})",
                        -length / 6.0,
                        length / 30.0
                    ),
                )
                .replace("iterations: 20000", "iterations: 80000");
            assert!(text.contains(&format!("sigma: {sigma}")) && text.contains("planes: 11"));
            let path = Path::new("scenes/fluid/tether_tube.ron");
            let scene = Scene::from_ron_str(&text, path).unwrap();
            let dir = out.path().join(format!("n{n}_{start}"));
            let summary = remembrane::workflow::run::run_scene(
                &scene,
                path,
                &RunOptions::quiet(&dir),
                |_| Ok(()),
            )
            .unwrap();
            assert!(
                summary.minimiser.as_ref().unwrap().converged,
                "n = {n}, start {start}"
            );
            let second_half = |column: &str| {
                let v = common::series_column(&dir, column);
                let mut h = v[v.len() / 2..].to_vec();
                h.sort_by(f64::total_cmp);
                (h[h.len() / 2], v[v.len() / 2..].to_vec())
            };
            let (r, _) = second_half("radius_tube");
            assert!(
                (r / r0 - 1.0).abs() < 0.01,
                "n = {n}, start {start}: radius {r} against {r0}"
            );
            let bound = if n == 10 { 0.05 } else { 0.03 };
            for end in ["force_top", "force_bottom"] {
                let (f, all) = second_half(end);
                assert!(
                    (f / f0 - 1.0).abs() < bound,
                    "n = {n}, start {start}: {end} {f} against {f0}"
                );
                let mean = all.iter().sum::<f64>() / all.len() as f64;
                let sd =
                    (all.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / all.len() as f64).sqrt();
                assert!(
                    sd / mean < 0.02,
                    "n = {n}, start {start}: {end} CV {}",
                    sd / mean
                );
            }
        }
    }
}

#[test]
fn a_resolution_ladder_continues_the_fluid_red_blood_cell_onto_a_refined_mesh() {
    // The first two rungs of scenes/fluid/red_blood_cell_l5.ron from the
    // CLI: the 642-vertex equilibrium, every triangle split into four, then
    // minimised at h = 1/2. Measured (Sobolev minimiser): 475 and 369
    // iterations, E_b/8πκ -1.87 % and -0.47 % against the continuum.
    let dir = tempfile::tempdir().unwrap();
    let bundled = std::fs::read_to_string("scenes/fluid/red_blood_cell_l5.ron").unwrap();
    let text = bundled.replace("Ladder(refinements: 2)", "Ladder(refinements: 1)");
    assert_ne!(text, bundled);
    let path = dir.path().join("ladder.ron");
    std::fs::write(&path, &text).unwrap();
    let out = dir.path().join("out");
    assert_eq!(
        common::cli(&[&"run", &path, &"--out", &out, &"--quiet"]),
        std::process::ExitCode::SUCCESS
    );
    let error = |phase: &str| {
        let summary = common::summary(&out.join(phase));
        assert!((summary.last.reduced_volume.unwrap() - 0.6).abs() < 1e-4);
        assert!((summary.last.area / 553.0 - 1.0).abs() < 1e-4);
        let eb = common::term_energy(&summary, "bending") / (8.0 * std::f64::consts::PI * 5.0);
        (summary.last.vertices as u64, eb / 1.95568 - 1.0)
    };
    let (v1, coarse) = error("h1");
    let (v2, fine) = error("h1_2");
    // V' = V + E = V + 3(V - 2) for a closed triangulated sphere.
    assert_eq!(v2, v1 + 3 * (v1 - 2));
    let first = common::series_column(&out.join("h1_2"), "vertices")[0];
    assert_eq!(first as u64, v2);
    assert!(fine.abs() < 0.006, "h = 1/2: {fine}");
    let order = (coarse.abs() / fine.abs()).log2();
    assert!(order >= 1.5, "errors {coarse} and {fine}: order {order}");
}

#[test]
fn the_bundled_ladders_are_the_fluid_red_blood_cell_at_finer_resolution() {
    // scenes/fluid/red_blood_cell_l5.ron and _l6.ron repeat
    // red_blood_cell.ron; only their names and resolutions may differ.
    let cell = Scene::load(Path::new("scenes/fluid/red_blood_cell.ron")).unwrap();
    for (file, refinements) in [("l5", 2), ("l6", 3)] {
        let mut ladder = Scene::load(Path::new(&format!(
            "scenes/fluid/red_blood_cell_{file}.ron"
        )))
        .unwrap();
        assert_eq!(
            ladder.resolution,
            remembrane::scene::resolution::Resolution::Ladder { refinements }
        );
        ladder.resolution = cell.resolution;
        ladder.name = cell.name.clone();
        assert_eq!(ladder, cell, "{file}");
    }
}

#[test]
fn a_refined_state_is_checked_before_it_is_read() {
    for (extra, reason) in [
        ("refine: 4)", "must be at most 3"),
        ("refine: 1), lipid_density: true", "without a lipid density"),
    ] {
        let text = format!(
            "Scene(name: \"r\", membrane: State(path: \"state.json\", {extra}, \
             energy: [Vin(), Bending(kappa: 5.0)])"
        );
        let e = Scene::from_ron_str(&text, Path::new("refined.ron"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("refined.ron"), "{e}");
        assert!(e.contains("membrane.refine"), "{e}");
        assert!(e.contains(reason), "{e}");
    }
}

#[test]
fn fluid_gradient_flow_never_raises_the_shape_energy_nor_pushes_the_vesicle() {
    // A jittered oblate spheroid relaxing by overdamped dynamics at fixed
    // area and volume, no remeshing: between events the flow is a gradient
    // flow of the shape energy (bending here; the constraints' multipliers
    // do no work at fixed A and V), and no force moves the free vesicle as
    // a whole. Measured over 3000 ticks: no rise at all; net force at
    // round-off (0.39 Ē/l̄ from the tangential projection alone).
    let text = "Scene(name: \"flow\", seed: 1, \
         membrane: Ellipsoid(level: 3, semi_axes: (7.5, 7.5, 5.0), jitter: 0.2), \
         model: Fluid(flips: None), energy: [Vin(form: Exact), Bending(kappa: 5.0)], \
         constraints: (area: OfInitial(1.0), volume: OfInitial(1.0)), remesh: (mode: Off))";
    let path = Path::new("flow.ron");
    let mut sim = Scene::from_ron_str(text, path)
        .unwrap()
        .build(path)
        .unwrap();
    let mut last = f64::INFINITY;
    let mut first = None;
    for tick in 0..1000 {
        sim.tick().unwrap();
        let buffers = sim.evaluate_forces().unwrap();
        let k = buffers.names().iter().position(|n| n == "bending").unwrap();
        let energy = buffers.evaluation.energies[k];
        let net = buffers.evaluation.total.iter().copied().sum::<DVec3>();
        let largest = buffers
            .evaluation
            .total
            .iter()
            .map(|f| f.length())
            .fold(0.0, f64::max);
        drop(buffers);
        assert!(
            energy <= last * (1.0 + 1e-8),
            "tick {tick}: E_b {energy} after {last}"
        );
        assert!(net.length() < 1e-6, "tick {tick}: net force {net:?}");
        assert!(largest > 1e-3, "the flow has stopped at tick {tick}");
        first.get_or_insert(energy);
        last = energy;
    }
    assert!(last < first.unwrap(), "{last} {first:?}");
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn refining_the_fluid_red_blood_cell_converges_at_order_two() {
    // The same cell (A = 553 l̄², v = 0.6) at h = 1 (642 vertices) and
    // h = 1/2 (2562): in the fluid model the bending energy's error against
    // the continuum (1.95568) falls at order ≥ 1.5 (measured: -1.87 % and
    // -0.48 %, order 1.95; the paper's model is an elastic shell whose
    // weight grows as (R/h)², see docs/fluid.md).
    let base = std::fs::read_to_string("scenes/fluid/red_blood_cell.ron").unwrap();
    let error = |level: u32, h: f64, tolerance: f64| -> f64 {
        let text = base
            .replace("level: 3,", &format!("level: {level},"))
            .replace(
                "model: Fluid(),",
                &format!("model: Fluid(), resolution: EdgeLength({h}),"),
            )
            .replace(
                "force_tolerance: 1e-3",
                &format!("force_tolerance: {tolerance}"),
            );
        let summary = converged_cell(&text, "refined.ron");
        common::term_energy(&summary, "bending") / (8.0 * std::f64::consts::PI * 5.0) / 1.95568
            - 1.0
    };
    // The force tolerance is scaled by h² (a vertex's force ∝ its area);
    // 4e-3 at h = 1/2 stops at the same 1e-3 as the bundled scene, where
    // the energy agrees with a 4× tighter stop to 1e-4.
    let (coarse, fine) = (error(3, 1.0, 1e-3), error(4, 0.5, 4e-3));
    let order = (coarse.abs() / fine.abs()).log2();
    eprintln!("E_b error: h = 1 {coarse:.4e}, h = 1/2 {fine:.4e}, order {order:.2}");
    assert!(fine.abs() < coarse.abs());
    assert!(order >= 1.5, "order {order}");
}

/// `physical_forces: Normal` keeps only the normal component of every
/// physical term's force, less its net force and torque (on this
/// symmetric mesh the projection leaves no torque, so one uniform vector
/// is taken away); the default keeps them whole.
#[test]
fn normal_physical_forces_keep_only_the_normal_components() {
    let text = |physical: &str| {
        format!(
            "Scene(name: \"n\", membrane: Ellipsoid(level: 2, semi_axes: (3.0, 3.5, 4.5)), \
             model: Fluid({physical}), energy: [Vin(form: Exact), \
             Bending(kappa: 5.0, discretisation: Dihedral), Tension(sigma: 0.3)])"
        )
    };
    let forces = |physical: &str| {
        let path = Path::new("normal.ron");
        let scene = Scene::from_ron_str(&text(physical), path).unwrap();
        let mut sim = scene.build(path).unwrap();
        let buffers = sim.evaluate_forces().unwrap();
        let names = buffers.names().to_vec();
        let terms = buffers.evaluation.term_forces.clone();
        drop(buffers);
        let p = sim.positions();
        let t = sim.membrane().cached_topology().clone();
        let normals: Vec<DVec3> = (0..p.len()).map(|v| vertex_normal(&p, &t, v)).collect();
        (names, terms, normals, p)
    };
    let (names, full, normals, positions) = forces("");
    let (_, normal, _, _) = forces("physical_forces: Normal");
    let mut tangential_before = 0.0f64;
    for name in ["bending", "tension"] {
        let k = names.iter().position(|n| n == name).unwrap();
        let net = normal[k].iter().copied().sum::<DVec3>();
        assert!(net.length() < 1e-9, "{name}: net force {net:?}");
        let torque = remembrane::fluid::torque(&normal[k], &positions);
        assert!(torque.length() < 1e-9, "{name}: torque {torque:?}");
        // What was taken away is one uniform vector.
        let mean = full[k]
            .iter()
            .zip(&normals)
            .map(|(f, n)| f.dot(*n) * *n)
            .sum::<DVec3>()
            / normals.len() as f64;
        for (v, n) in normals.iter().enumerate() {
            let (f, g) = (full[k][v], normal[k][v]);
            assert!(
                (g - (f.dot(*n) * *n - mean)).length() < 1e-12,
                "{name} vertex {v}"
            );
            tangential_before = tangential_before.max((f - f.dot(*n) * *n).length());
        }
    }
    // The default keeps a tangential part on this irregular mesh.
    assert!(tangential_before > 1e-3, "{tangential_before}");
}
