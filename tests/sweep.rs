//! Sweeps: expansion, seeds, shards, resumption, errors; and collect.

use remembrane::collect::{CollectOptions, collect, polyfit, polyval};
use remembrane::sweep::{Sweep, SweepOptions, parse_shard, run_sweep, slurm_script};
use std::collections::HashSet;
use std::path::Path;

/// A small sweep over the bundled sphere scene: 2 conditions × κ ∈ {1, 2}
/// × 2 repeats, 40 iterations and 20 frames each.
fn write_sweep(dir: &Path) -> std::path::PathBuf {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sphere.ron");
    let text = format!(
        r#"Sweep(
    name: "mini",
    scene: "{}",
    repeats: 2,
    seed: 7,
    conditions: [
        (name: "soft", set: [Iterations(40)]),
        (name: "stiff", set: [Iterations(40), VolumeStrength(1.0)]),
    ],
    grid: [(name: "kappa", values: [Kappa(1.0), Kappa(2.0)])],
)"#,
        scene.display()
    );
    let path = dir.join("mini.ron");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn expansion_gives_distinct_seeds_and_shards_partition_the_runs() {
    let dir = tempfile::tempdir().unwrap();
    // The sphere scene has no Volume term: the "stiff" condition is refused.
    let err = Sweep::load(&write_sweep(dir.path()))
        .unwrap_err()
        .to_string();
    assert!(err.contains("conditions[1].set[1]"), "{err}");
    assert!(err.contains("no Volume term"), "{err}");

    let path = dir.path().join("ok.ron");
    let text = std::fs::read_to_string(write_sweep(dir.path()))
        .unwrap()
        .replace(", VolumeStrength(1.0)", "");
    std::fs::write(&path, text).unwrap();
    let (sweep, _) = Sweep::load(&path).unwrap();
    let runs = sweep.expand();
    assert_eq!(runs.len(), 2 * 2 * 2);
    let seeds: HashSet<u64> = runs.iter().map(|r| r.seed).collect();
    assert_eq!(seeds.len(), runs.len(), "distinct seeds");
    let dirs: HashSet<_> = runs.iter().map(|r| r.dir.clone()).collect();
    assert_eq!(dirs.len(), runs.len(), "distinct directories");
    assert_eq!(
        runs[3].dir,
        Path::new("runs/soft/kappa=2/rep01"),
        "condition, grid point, repeat"
    );
    // Shards I/3 take every run exactly once.
    let mut seen = vec![0; runs.len()];
    for i in 0..3 {
        for r in runs.iter().filter(|r| r.index % 3 == i) {
            seen[r.index] += 1;
        }
    }
    assert!(seen.iter().all(|&n| n == 1));
    assert_eq!(parse_shard("2/3").unwrap(), (2, 3));
    assert!(parse_shard("3/3").is_err());
    assert!(parse_shard("x").is_err());
    let script = slurm_script(
        "mini",
        Path::new("/opt/remembrane"),
        &path,
        Path::new("/data/out"),
        4,
    );
    assert!(script.contains("#SBATCH --array=0-3"));
    assert!(script.contains("--shard \"${SLURM_ARRAY_TASK_ID}/4\""));
}

#[test]
fn shards_run_their_share_resume_and_collect_sees_every_run() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ok.ron");
    let text = std::fs::read_to_string(write_sweep(dir.path()))
        .unwrap()
        .replace(", VolumeStrength(1.0)", "");
    std::fs::write(&path, text).unwrap();
    let out = dir.path().join("out");
    let options = |shard| SweepOptions {
        out: out.clone(),
        jobs: 2,
        shard,
        iterations: None,
        quiet: true,
    };
    let energy_over_time = CollectOptions {
        x: "time".into(),
        y: "energy_total".into(),
        ..Default::default()
    };
    let first = run_sweep(&path, &options(Some((0, 2)))).unwrap();
    assert_eq!((first.total, first.in_shard, first.completed), (8, 4, 4));
    // Collect before the other shard: 4 runs missing, reported.
    let partial = collect(&out, &energy_over_time).unwrap();
    assert_eq!((partial.expected, partial.missing.len()), (8, 4));
    let second = run_sweep(&path, &options(Some((1, 2)))).unwrap();
    assert_eq!((second.completed, second.skipped), (4, 0));
    // Everything done: a rerun skips all.
    let again = run_sweep(&path, &options(None)).unwrap();
    assert_eq!((again.completed, again.skipped), (0, 8));

    let report = collect(&out, &energy_over_time).unwrap();
    assert!(report.missing.is_empty());
    assert_eq!(report.runs.len(), 8);
    assert_eq!(report.groups.len(), 4);
    for g in &report.groups {
        assert_eq!(g.n, 2);
        assert!(g.mean.is_finite());
    }
    // Bending energy is proportional to κ: the κ = 2 groups end at twice
    // the κ = 1 groups' fitted final energy (same mesh, same dynamics up to
    // time scaling).
    let soft: Vec<f64> = report
        .groups
        .iter()
        .filter(|g| g.condition == "soft")
        .map(|g| g.mean)
        .collect();
    assert!(soft[1] > 1.5 * soft[0], "{soft:?}");
    for f in [
        "collect.csv",
        "collect_runs.csv",
        "fig5f.png",
        "fig5e_kappa=1.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let table = std::fs::read_to_string(out.join("collect.csv")).unwrap();
    assert_eq!(table.lines().count(), 1 + 4);
    assert!(table.starts_with("condition,kappa,runs,"));
}

#[test]
fn polynomial_fit_recovers_a_quartic() {
    let c = [0.3, -1.0, 2.0, 0.5, -0.25];
    let points: Vec<(f64, f64)> = (0..30)
        .map(|i| {
            let x = 0.5 + i as f64 / 58.0;
            (x, polyval(&c, x))
        })
        .collect();
    let fit = polyfit(&points, 4).unwrap();
    for (a, b) in fit.iter().zip(&c) {
        assert!((a - b).abs() < 1e-6, "{fit:?}");
    }
    assert!(polyfit(&points[..4], 4).is_none());
}

#[test]
fn the_bundled_tether_sweep_expands_to_the_papers_scan() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tether_sweep.ron");
    let (sweep, _) = Sweep::parse(&path).unwrap();
    let runs = sweep.expand();
    // 3 conditions × 6 k_d × 8 repeats.
    assert_eq!(runs.len(), 144);
    assert_eq!(
        runs[0].point,
        vec![("k_d".to_string(), "0.025".to_string())]
    );
    assert_eq!(runs[0].point_values, vec![Some(0.025)]);
    let conditions: HashSet<&str> = runs.iter().map(|r| r.condition.as_str()).collect();
    assert_eq!(conditions, HashSet::from(["naive", "barrier", "reservoir"]));
}
