//! Remeshing an open membrane with a held rim (issue 32 item 3): a disc
//! under tension, its rim pinned or on a roller, pulled up at its centre by
//! a control point moved upward every few iterations, stretches its edges
//! past the barrier and splits them. The mesh stays valid, the rim stays
//! one loop, its original vertices keep their held coordinates bit for bit
//! and every vertex on it, new ones included, is held.

use crate::common;

use remembrane::engine::shared_resources::PinnedVertices;
use remembrane::engine::simulation::{Simulation, StopRequest};
use remembrane::remesh::RemeshStats;
use remembrane::scene::Scene;
use std::path::{Path, PathBuf};

const PULLED: &str = r#"Scene(
    name: "pulled_patch",
    seed: 3,
    membrane: Disc(radius: 5.0, mean_edge_length: 1.0),
    energy: [
        Vin(form: Exact),
        Bending(kappa: 1.0),
        Tension(sigma: 0.05),
        Springs(coupling: Centroid, stiffness: 4.0),
    ],
    control_points: [(position: (0.0, 0.0, 0.5), name: "tip")],
    control_point_schedule: [
        (when: Every(interval: INTERVAL, start: 0), points: [0], change: MoveBy(0.0, 0.0, 0.25)),
    ],
    boundary: [BOUNDARY],
    DYNAMICS,
    remesh: (mode: FreeEnergy),
)"#;

const PINNED: &str = "Pinned(loop: 0)";
const ROLLER: &str = "Roller(loop: 0, direction: (0.0, 0.0, 1.0))";
const OVERDAMPED: &str = "dynamics: (iterations: 3000, frames: 2)";
const MINIMISER: &str =
    "dynamics: (method: Minimise(force_tolerance: 1e-4), iterations: 3000, frames: 2)";

fn scene(boundary: &str, dynamics: &str, interval: u32) -> String {
    PULLED
        .replace("BOUNDARY", boundary)
        .replace("DYNAMICS", dynamics)
        .replace("INTERVAL", &interval.to_string())
}

fn write(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("pulled.ron");
    std::fs::write(&path, text).unwrap();
    path
}

fn positions(sim: &Simulation) -> Vec<glam::DVec3> {
    let mut p = Vec::new();
    sim.membrane().gather_positions(&mut p);
    p
}

/// Runs the scene to its end and checks the rim; returns the splits and
/// the rim's vertices at the start and at the end.
fn run_and_check_rim(text: &str, pinned: bool) -> u64 {
    run_and_check_rim_with(text, pinned, 2.0).0
}

fn run_and_check_rim_with(text: &str, pinned: bool, min_tip: f64) -> (u64, usize, usize) {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), text);
    let mut sim = Scene::load(&path).unwrap().build(&path).unwrap();
    let t = sim.membrane().cached_topology().clone();
    let before = positions(&sim);
    let rim: Vec<_> = t.boundary_loops()[0]
        .iter()
        .map(|&v| (t.vertex_entities[v as usize], before[v as usize]))
        .collect();
    for _ in 0..3000 {
        if sim.resource::<StopRequest>().0.is_some() {
            break;
        }
        sim.tick().unwrap();
    }
    let t = sim.membrane().cached_topology().clone();
    let after = positions(&sim);
    remembrane::mesh::check_mesh(&after, &t.faces, None).unwrap();
    let loops = t.boundary_loops();
    assert_eq!(loops.len(), 1, "the rim is one loop");
    for &(e, x) in &rim {
        let v = t
            .vertex_slot(e)
            .expect("a held vertex is never merged away");
        let y = after[v as usize];
        if pinned {
            assert_eq!(y, x, "rim vertex {v} moved");
        } else {
            assert_eq!(
                y.z.to_bits(),
                x.z.to_bits(),
                "rim vertex {v} left its plane"
            );
        }
    }
    let held = sim.resource::<PinnedVertices>().clone();
    assert!(loops[0].len() >= rim.len());
    for &v in &loops[0] {
        assert_eq!(after[v as usize].z, 0.0, "rim vertex {v} is off z = 0");
        let k = held.vertices.iter().position(|&s| s == v);
        let k = k.unwrap_or_else(|| panic!("rim vertex {v} is not held"));
        assert_eq!(held.entities[k], t.vertex_entities[v as usize]);
        assert_eq!(held.positions[k].z, 0.0);
    }
    assert_eq!(
        held.vertices.len(),
        loops[0].len(),
        "only rim vertices are held"
    );
    let tip = after.iter().map(|p| p.z).fold(f64::MIN, f64::max);
    assert!(tip >= min_tip, "the patch was not pulled up ({tip})");
    let stats = sim.resource::<RemeshStats>();
    eprintln!(
        "splits {} merges {} rim {} -> {} tip {tip:.2}",
        stats.split.success,
        stats.merge.success,
        rim.len(),
        loops[0].len()
    );
    (stats.split.success, rim.len(), loops[0].len())
}

#[test]
fn a_pulled_pinned_patch_splits_and_keeps_its_rim() {
    assert!(run_and_check_rim(&scene(PINNED, OVERDAMPED, 100), true) > 0);
}

#[test]
fn a_pulled_roller_patch_splits_and_keeps_its_rim_in_its_plane() {
    assert!(run_and_check_rim(&scene(ROLLER, OVERDAMPED, 100), false) > 0);
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_pulled_patch_under_the_minimiser_splits_and_keeps_its_rim() {
    assert!(run_and_check_rim(&scene(PINNED, MINIMISER, 5), true) > 0);
}

#[test]
fn the_cli_runs_a_remeshed_pinned_patch() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), &scene(PINNED, OVERDAMPED, 100));
    let out_dir = dir.path().join("out");
    common::run_binary(&path, &out_dir);
    let series = std::fs::read_to_string(out_dir.join("series.csv")).unwrap();
    let mut lines = series.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header
        .iter()
        .position(|&h| h == "splits")
        .expect("splits column");
    let splits: f64 = lines
        .map(|l| l.split(',').nth(col).unwrap().parse::<f64>().unwrap())
        .sum();
    assert!(splits > 0.0, "no split in series.csv");
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_split_roller_rim_edge_gives_its_new_vertex_the_condition() {
    // A flat disc pushed to a larger area (no pull) expands in its plane:
    // its rim slides outward on the roller and its edges stretch past the
    // barrier. Their new vertices are held in z = 0 like the others.
    let text = scene(ROLLER, OVERDAMPED, 100000).replace(
        "Tension(sigma: 0.05)",
        "Area(k: 200.0, target: OfInitial(2.0))",
    );
    let (splits, before, after) = run_and_check_rim_with(&text, false, 0.0);
    assert!(splits > 0);
    assert!(
        after > before,
        "no rim edge was split ({before} -> {after})"
    );
}
