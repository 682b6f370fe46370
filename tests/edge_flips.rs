//! Edge flips as Metropolis moves: the energy change computed from a flip's
//! few faces equals the difference of the whole energy, and flipping keeps
//! every mesh invariant.

mod common;

use glam::DVec3;
use remembrane::energy::bending::{BendingScratch, bending};
use remembrane::energy::vin::{Segmentation, VinForm, VinParams};
use remembrane::mesh::geometry::{enclosed_volume, face_geometry, total_area};
use remembrane::mesh::icosphere;
use remembrane::mesh::membrane::Membrane;
use remembrane::remesh::flip::{Flip, FlipEnergy, FlipTotals};
use std::sync::Arc;

/// The whole energy of the terms in `model` for `faces` at `p`.
fn whole_energy(model: &FlipEnergy, p: &[DVec3], faces: &[[u32; 3]]) -> f64 {
    let mut e = 0.0;
    if let Some((seg, _)) = &model.vin {
        let mut seen = std::collections::BTreeSet::new();
        for f in faces {
            for k in 0..3 {
                let (a, b) = (f[k].min(f[(k + 1) % 3]), f[k].max(f[(k + 1) % 3]));
                if seen.insert((a, b)) {
                    e += seg.linear(p[a as usize].distance(p[b as usize])).0;
                }
            }
        }
    }
    if let Some((kappa, c0)) = model.bending {
        let mut g = Vec::new();
        face_geometry(p, faces, &mut g);
        e += bending(
            p.len(),
            faces,
            &g,
            kappa,
            c0,
            &mut BendingScratch::default(),
            None,
        );
    }
    let volume = enclosed_volume(p, faces, p[0]);
    let area = total_area(p, faces);
    if let Some((k, t)) = model.volume {
        e += k * (volume - t).powi(2) / t;
    }
    if let Some((k, t)) = model.area {
        e += k * (area - t).powi(2) / t;
    }
    if let Some(sigma) = model.tension {
        e += sigma * area;
    }
    e
}

#[test]
fn a_flips_local_energy_change_is_the_whole_energy_difference() {
    let mut mesh = icosphere(3, 1.0);
    mesh.jitter(0.2, 7);
    let membrane = Membrane::from_mesh(&mesh, false).unwrap();
    let t = membrane.cached_topology().clone();
    let p = &mesh.positions;
    let totals = FlipTotals::of(p, &t.faces);
    let seg = Arc::new(Segmentation::new(VinParams::default()));
    for c0 in [0.0, 0.3] {
        let model = FlipEnergy {
            vin: Some((seg.clone(), VinForm::PiecewiseLinear)),
            bending: Some((1.5, c0)),
            volume: Some((1.0, 0.95 * totals.volume)),
            area: Some((2.0, 1.02 * totals.area)),
            tension: Some(0.1),
            springs: false,
        };
        let before = whole_energy(&model, p, &t.faces);
        let mut checked = 0;
        for edge in (0..t.edges.len() as u32).step_by(37) {
            let flip = Flip::of(&t, edge).unwrap();
            let mut faces = t.faces.clone();
            let [f0, f1] = flip.faces.map(|f| f as usize);
            let [n0, n1] = flip.new_faces();
            faces[f0] = n0;
            faces[f1] = n1;
            let whole = whole_energy(&model, p, &faces) - before;
            let local = model.change(&flip, &t, p, totals);
            assert!(
                (local.energy - whole).abs() < 1e-9 * before.abs().max(1.0),
                "edge {edge}, c0 {c0}: local {} whole {whole}",
                local.energy
            );
            let dv = enclosed_volume(p, &faces, p[0]) - totals.volume;
            assert!((local.volume - dv).abs() < 1e-9, "{} {dv}", local.volume);
            checked += 1;
        }
        assert!(checked > 40);
    }
}

/// The bundled fluid vesicle (`scenes/fluctuating/flips.ron`) for 2000
/// ticks with every mesh invariant checked after each flip (tests run with
/// debug assertions): flips are taken, every proposal is counted once, and
/// the triangulation stays a valid closed mesh.
#[test]
fn flipping_keeps_every_invariant_and_counts_every_proposal() {
    let scene =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/fluctuating/flips.ron");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    assert_eq!(
        common::cli(&[
            &"run",
            &scene,
            &"--out",
            &out,
            &"--iterations",
            &"2000",
            &"--quiet"
        ]),
        std::process::ExitCode::SUCCESS
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let f = &summary["edge_flips"];
    let n = |k: &str| f[k].as_u64().unwrap();
    assert!(n("accepted") > 100, "{f}");
    assert_eq!(
        n("proposed"),
        n("accepted") + n("rejected_topology") + n("rejected_geometry") + n("rejected_energy")
    );
    // 0.01 proposals per edge per tick on 1920 edges: 19.2 per tick.
    assert!((n("proposed") as f64 - 2000.0 * 19.2).abs() < 500.0, "{f}");
}

/// A scene whose energy has a term a flip's ΔE does not cover is refused,
/// naming the field and the term.
#[test]
fn flips_under_a_term_without_a_local_energy_change_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.ron");
    std::fs::write(
        &path,
        r#"Scene(
        membrane: Icosphere(level: 2),
        energy: [Vin(), Bending(kappa: 1.5), SelfAvoidance()],
        edge_flips: (attempts_per_edge: 0.01),
    )"#,
    )
    .unwrap();
    let message = remembrane::scene::Scene::load(&path)
        .unwrap_err()
        .to_string();
    assert!(message.contains("bad.ron"), "{message}");
    assert!(message.contains("edge_flips"), "{message}");
    assert!(message.contains("energy[2] is SelfAvoidance"), "{message}");
    // An empty edge range would refuse every flip without a word.
    std::fs::write(
        &path,
        r#"Scene(
        membrane: Icosphere(level: 2),
        energy: [Vin(), Bending(kappa: 1.5)],
        edge_flips: (attempts_per_edge: 0.01, edge_range: (1.5, 0.7)),
    )"#,
    )
    .unwrap();
    let message = remembrane::scene::Scene::load(&path)
        .unwrap_err()
        .to_string();
    assert!(message.contains("edge_flips.edge_range"), "{message}");
    assert!(message.contains("0 < min < max"), "{message}");
}

/// A noisy scene with split/merge remeshing is told that its thermal
/// averages are biased (by `check`, `run` and summary.json); the same
/// vesicle fluid by flips is not.
#[test]
fn noise_with_split_merge_remeshing_carries_a_caution_and_flips_do_not() {
    let scenes = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/fluctuating");
    let load = |name: &str| remembrane::scene::Scene::load(&scenes.join(name)).unwrap();
    let cautions = load("fluid.ron").cautions();
    assert_eq!(cautions.len(), 1, "{cautions:?}");
    assert!(cautions[0].contains("edge_flips"), "{cautions:?}");
    assert!(load("flips.ron").cautions().is_empty());
    assert!(load("tethered.ron").cautions().is_empty());
}

/// With control-point springs, flips never touch a point's nearest vertex,
/// so the springs' energy is unchanged by every flip. Nine weak springs sit
/// on nine valence-6 vertices of the flip vesicle (10× the proposals);
/// after 3000 ticks each vertex has the 1-ring it started with. Without the
/// rule, 329 of the 642 vertices' rings change in the same run (no springs),
/// and some of the nine do.
#[test]
fn flips_leave_the_rings_under_control_points_alone() {
    use remembrane::engine::simulation::DensePositions;
    let mesh = icosphere(3, 1.0);
    let m = Membrane::from_mesh(&mesh, false).unwrap();
    let t = m.cached_topology();
    let targets: Vec<DVec3> = (0..mesh.positions.len())
        .filter(|&v| t.valence(v) == 6)
        .step_by(75)
        .map(|v| mesh.positions[v] * 1.01)
        .collect();
    assert_eq!(targets.len(), 9);
    let points: Vec<String> = targets
        .iter()
        .map(|p| format!("(position: ({}, {}, {}))", p.x, p.y, p.z))
        .collect();
    let flips = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/fluctuating/flips.ron"),
    )
    .unwrap();
    let text = flips
        .replace(
            "        Area(k: 20.0, target: OfInitial(1.0)),",
            "        Area(k: 20.0, target: OfInitial(1.0)),\n        Springs(stiffness: 1.0, coupling: Centroid),",
        )
        .replace(
            "    penalty_smoothing: 0,",
            &format!(
                "    penalty_smoothing: 0,\n    control_points: [{}],",
                points.join(", ")
            ),
        )
        .replace("attempts_per_edge: 0.01", "attempts_per_edge: 0.1");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("pinned.ron");
    std::fs::write(&path, text).unwrap();
    let mut sim = remembrane::scene::Scene::load(&path)
        .unwrap()
        .build(&path)
        .unwrap();
    let rings = |sim: &remembrane::engine::simulation::Simulation| {
        let p = &sim.resource::<DensePositions>().0;
        let membrane = sim.membrane();
        let t = membrane.cached_topology();
        targets
            .iter()
            .map(|target| {
                let v = (0..p.len())
                    .min_by(|&i, &j| p[i].distance(*target).total_cmp(&p[j].distance(*target)))
                    .unwrap();
                let mut ring: Vec<u64> = t
                    .neighbours(v)
                    .iter()
                    .map(|&w| t.vertex_entities[w as usize].to_bits().get())
                    .collect();
                ring.sort();
                (t.vertex_entities[v].to_bits().get(), ring)
            })
            .collect::<Vec<_>>()
    };
    sim.evaluate_forces().unwrap();
    let before = rings(&sim);
    for _ in 0..3000 {
        sim.tick().unwrap();
    }
    let stats = *sim.resource::<remembrane::systems::edge_flips::FlipStats>();
    assert!(stats.accepted > 1000, "{stats:?}");
    assert_eq!(rings(&sim), before);
}
