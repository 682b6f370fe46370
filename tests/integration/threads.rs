//! Results do not depend on the thread count: a 10242-vertex membrane with
//! thermal noise and remeshing, run on pools of 1, 2 and 3 threads, writes
//! byte-identical run directories (all files; `summary.json` without its
//! wall-clock timings).
//!
//! The grain is lowered to 128 elements per task (loops split from 1024)
//! so that every loop over
//! the 10242 vertices, 20480 faces and 30720 edges splits: on one thread
//! every kernel runs its serial loop, on two or three its parallel form and
//! the force terms run concurrently, so this compares the two forms bit for
//! bit.

use crate::common;
use remembrane::workflow::run::RunOptions;

use remembrane::scene::Scene;
use std::path::{Path, PathBuf};

/// A run directory's files and their bytes ([`common::run_contents`]).
type RunFiles = std::collections::BTreeMap<PathBuf, Vec<u8>>;

/// The scaled red blood cell (level 5) with k_BT = 0.02 Ē: noisy enough
/// that a few hundred edges cross a barrier and are remeshed in 120 ticks.
fn noisy_scene() -> (Scene, PathBuf) {
    let path = crate::common::repo("scenes/scaled/red_blood_cell_l5.ron");
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("temperature: 0.0,"));
    let text = text.replace("temperature: 0.0,", "temperature: 0.02,");
    (Scene::from_ron_str(&text, &path).unwrap(), path)
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_noisy_remeshing_10242_vertex_run_is_byte_identical_on_1_2_and_3_threads() {
    remembrane::util::parallel::set_grain(128);
    let (scene, path) = noisy_scene();
    let runs = run_on_1_2_and_3_threads(&scene, &path, 120);
    let summary: serde_json::Value =
        serde_json::from_slice(&runs[0].1[Path::new("summary.json")]).unwrap();
    let events = summary["remesh"]["events"].as_u64().unwrap();
    assert!(events >= 50, "the run must remesh: {events} events");
    assert_eq!(summary["vertices"].as_u64().map(|v| v > 10_000), Some(true));
    assert_same_runs(&runs);
}

/// The fluctuating vesicle (2562 vertices at 300 K, fluid by Metropolis
/// edge flips) on 1, 2 and 3 threads: byte-identical run directories. The
/// flips are drawn and taken serially from a per-tick stream, between
/// parallel kernels (grain lowered as above, so every loop splits).
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_vesicle_fluid_by_edge_flips_is_byte_identical_on_1_2_and_3_threads() {
    remembrane::util::parallel::set_grain(128);
    let path = crate::common::repo("scenes/fluctuating_vesicle.ron");
    let scene = Scene::load(&path).unwrap();
    let runs = run_on_1_2_and_3_threads(&scene, &path, 300);
    let summary: serde_json::Value =
        serde_json::from_slice(&runs[0].1[Path::new("summary.json")]).unwrap();
    let accepted = summary["edge_flips"]["accepted"].as_u64().unwrap();
    assert!(accepted >= 50, "the run must flip: {accepted} flips");
    assert_same_runs(&runs);
}

/// Runs `scene` for `iterations` (two frames) on pools of 1, 2 and 3
/// threads: (thread count, the run directory's files) each.
fn run_on_1_2_and_3_threads(scene: &Scene, path: &Path, iterations: u64) -> Vec<(usize, RunFiles)> {
    let root = tempfile::tempdir().unwrap();
    let mut runs = Vec::new();
    for threads in [1, 2, 3] {
        let out = root.path().join(format!("threads_{threads}"));
        let mut opts = RunOptions::quiet(&out);
        opts.iterations = Some(iterations);
        opts.frames = Some(2);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let summary = pool
            .install(|| remembrane::workflow::run::run_scene(scene, path, &opts, |_| Ok(())))
            .unwrap();
        assert_eq!(summary.iterations, iterations);
        runs.push((threads, common::run_contents(&out)));
    }
    runs
}

/// Every run directory in `runs` (thread count, files) has the same files
/// with the same bytes as the first.
fn assert_same_runs(runs: &[(usize, RunFiles)]) {
    let (_, first) = &runs[0];
    for (threads, files) in &runs[1..] {
        assert_eq!(
            first.keys().collect::<Vec<_>>(),
            files.keys().collect::<Vec<_>>(),
            "{threads} threads: same files"
        );
        for (name, bytes) in first {
            assert!(
                files[name] == *bytes,
                "{threads} threads: {} differs from the one-thread run",
                name.display()
            );
        }
    }
}
