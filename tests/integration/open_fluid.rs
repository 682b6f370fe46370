//! The fluid model on open membranes (issue 32): on a boundary vertex the
//! shape-keeping slides are along the boundary line, so the maintenance
//! forces keep only that component and the physical ones lose only it; a
//! held rim takes the net force and torque, which are then not removed.
//! End to end, a free rim under a line tension settles where the area
//! penalty's tension balances it, λ/R, which V_in's elastic sheet in the
//! paper's model does not let it do.

use glam::DVec3;
use remembrane::engine::force::{ForceBuffers, ForceKind};
use remembrane::engine::simulation::{Simulation, StopRequest};
use remembrane::scene::Scene;

const FREE_RIM: &str = r#"Scene(
    name: "free_rim",
    seed: 1,
    membrane: Disc(radius: 6.0, mean_edge_length: 1.0),
    model: Fluid(physical_forces: Normal),
    energy: [
        Vin(form: Exact),
        Area(k: 1.0, target: OfInitial(1.0)),
    ],
    penalty_smoothing: 0,
    boundary: [Free(loop: 0, line_tension: 0.2)],
    dynamics: (method: Minimise(force_tolerance: 1e-7), iterations: 20000),
    remesh: (mode: Off),
)"#;

fn build(text: &str) -> Simulation {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("open_fluid.ron");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap().build(&path).unwrap()
}

fn positions(sim: &Simulation) -> Vec<DVec3> {
    let mut p = Vec::new();
    sim.membrane().gather_positions(&mut p);
    p
}

fn run_to_rest(sim: &mut Simulation) {
    for _ in 0..20000 {
        if sim.resource::<StopRequest>().0.is_some() {
            return;
        }
        sim.tick().unwrap();
    }
    panic!("the minimiser did not come to rest");
}

/// The area deficit (A0 − A)/A0 at rest, the rim's mean radius and its
/// vertex count.
fn rest_of_free_rim(text: &str) -> (f64, f64, usize) {
    let mut sim = build(text);
    let t = sim.membrane().cached_topology().clone();
    let area = |p: &[DVec3]| remembrane::mesh::geometry::total_area(p, &t.faces);
    let initial = area(&positions(&sim));
    run_to_rest(&mut sim);
    let p = positions(&sim);
    let rim = &t.boundary_loops()[0];
    let centre = p.iter().copied().sum::<DVec3>() / p.len() as f64;
    let radius = rim
        .iter()
        .map(|&v| (p[v as usize] - centre).length())
        .sum::<f64>()
        / rim.len() as f64;
    assert!(
        p.iter().all(|x| x.z.abs() < 1e-12),
        "the disc left its plane"
    );
    ((initial - area(&p)) / initial, radius, rim.len())
}

/// Balance of a rim vertex on a regular N-gon of circumradius R: the line
/// tension's inward 2λ sin(π/N) against the penalty's tension
/// σ = 2k(A − A0)/A0 on the half-chord R sin(2π/N), so
/// (A0 − A)/A0 = λ / (2kR cos(π/N)).
#[test]
fn a_free_fluid_rim_under_line_tension_settles_where_the_area_penalty_balances_it() {
    let (lambda, k) = (0.2, 1.0);
    let (deficit, radius, n) = rest_of_free_rim(FREE_RIM);
    let expected = lambda / (2.0 * k * radius * (std::f64::consts::PI / n as f64).cos());
    let error = deficit / expected - 1.0;
    eprintln!(
        "fluid: deficit {deficit:.6}, expected {expected:.6} (R = {radius:.4}, N = {n}), error {error:+.2e}"
    );
    // Measured +4e-6 (the generated rim is a regular 42-gon); the
    // tolerance leaves room for a rim that is not quite regular.
    assert!(error.abs() < 1e-3, "{error}");
    // In the paper's model V_in's in-plane elasticity holds the rim: the
    // deficit is not the penalty's (measured: the area grows by 0.44 %).
    let paper = FREE_RIM.replace("    model: Fluid(physical_forces: Normal),\n", "");
    let (deficit, radius, n) = rest_of_free_rim(&paper);
    let expected = lambda / (2.0 * k * radius * (std::f64::consts::PI / n as f64).cos());
    eprintln!("paper: deficit {deficit:.6}, expected {expected:.6}");
    assert!(
        (deficit / expected - 1.0).abs() > 0.5,
        "{deficit} {expected}"
    );
}

/// One force evaluation of `text` with its disc bent out of its plane, as
/// the per-term forces that act (after the fluid projection), with each
/// term's name and kind.
type TermForces = Vec<(String, ForceKind, Vec<DVec3>)>;

fn projected_forces(text: &str) -> (TermForces, Vec<DVec3>, Simulation) {
    let mut sim = build(text);
    let mut p = positions(&sim);
    for (i, x) in p.iter_mut().enumerate() {
        x.z = 0.3 * (0.7 * x.x).sin() * (0.5 * x.y).cos() + 0.05 * ((i * 7919) % 11) as f64 / 11.0;
    }
    let zeros = vec![DVec3::ZERO; p.len()];
    sim.membrane_mut().scatter_positions_and_forces(&p, &zeros);
    sim.tick().unwrap();
    let buffers = sim.resource::<ForceBuffers>();
    let terms = buffers
        .terms()
        .iter()
        .zip(&buffers.evaluation.term_forces)
        .map(|(t, f)| (t.name.clone(), t.kind, f.clone()))
        .collect();
    drop(buffers);
    (terms, p, sim)
}

/// With a pinned rim the projected forces are the boundary-aware
/// projections of the terms' forces; with a free rim they differ from them
/// only by the removed net force and torque, a rigid motion, which moves
/// no shape.
#[test]
fn on_a_boundary_maintenance_slides_along_the_rim_and_physics_acts_across_it() {
    let free = FREE_RIM
        .replace(
            "Area(k: 1.0, target: OfInitial(1.0)),",
            "Area(k: 1.0, target: OfInitial(1.0)),\n        \
             Bending(kappa: 1.0, discretisation: Dihedral),\n        Tension(sigma: 0.1),",
        )
        .replace("Minimise(force_tolerance: 1e-7)", "Minimise()");
    let pinned = free.replace("Free(loop: 0, line_tension: 0.2)", "Pinned(loop: 0)");
    let (held_terms, p, sim) = projected_forces(&pinned);
    let (free_terms, _, _) = projected_forces(&free);
    let t = sim.membrane().cached_topology().clone();
    let rim = t.boundary_loops()[0].clone();
    let tangent = |v: u32| {
        let ring = t.neighbours(v as usize);
        (p[ring[0] as usize] - p[ring[ring.len() - 1] as usize]).normalize()
    };
    let mut checked = 0;
    for (name, kind, held) in &held_terms {
        let scale = held.iter().map(|f| f.length()).fold(0.0, f64::max);
        assert!(scale > 1e-6, "{kind:?}: no force");
        for &v in &rim {
            let (f, t) = (held[v as usize], tangent(v));
            match kind {
                ForceKind::Maintenance => {
                    assert!(f.cross(t).length() < 1e-12 * scale, "{kind:?} {v}: {f}");
                }
                _ => assert!(f.dot(t).abs() < 1e-12 * scale, "{kind:?} {v}: {f}"),
            }
            checked += 1;
        }
        let net = held.iter().copied().sum::<DVec3>().length();
        if *kind == ForceKind::Maintenance {
            // Nothing uniform was taken from the vertices: the held rim
            // takes the net force.
            assert!(net > 1e-6 * scale, "{kind:?}: net force {net}");
        }
        // The free rim's line tension is a term of its own: compare the
        // others.
        let (_, _, free) = free_terms.iter().find(|(n, ..)| n == name).unwrap();
        let net = free.iter().copied().sum::<DVec3>().length();
        assert!(net < 1e-9 * scale, "{kind:?}: net force {net} left");
        let d: Vec<DVec3> = held.iter().zip(free).map(|(a, b)| *a - *b).collect();
        for i in (0..p.len()).step_by(7) {
            for j in (0..p.len()).step_by(5) {
                let rigid = (d[i] - d[j]).dot(p[i] - p[j]);
                assert!(rigid.abs() < 1e-10 * scale, "{kind:?} {i} {j}: {rigid}");
            }
        }
    }
    assert!(checked > 3 * rim.len());
}
