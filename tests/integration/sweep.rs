//! Sweeps: expansion, seeds, shards, resumption, errors; and collect.

use remembrane::workflow::collect::{CollectOptions, collect, polyfit, polyval};
use remembrane::workflow::slurm::slurm_script;
use remembrane::workflow::sweep::{Sweep, SweepOptions, parse_shard, run_sweep};
use std::collections::HashSet;
use std::path::Path;

/// A small sweep over the bundled sphere scene: 2 conditions × κ ∈ {1, 2}
/// × 2 repeats, 40 iterations and 20 frames each.
fn write_sweep(dir: &Path) -> std::path::PathBuf {
    let scene = crate::common::repo("scenes/sphere.ron");
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
        phases_only: false,
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
    // Outputs are read typed: a renamed column or summary field is an
    // error naming the file and the field, never a NaN.
    let run = out.join(&report.runs[0].spec.dir);
    let series = run.join("series.csv");
    let text = std::fs::read_to_string(&series).unwrap();
    std::fs::write(&series, text.replacen("energy_total", "energy_sum", 1)).unwrap();
    let e = collect(&out, &energy_over_time).unwrap_err().to_string();
    assert!(
        e.contains("series.csv") && e.contains("field `energy_total`"),
        "{e}"
    );
    std::fs::write(&series, text).unwrap();
    let summary = run.join("summary.json");
    let text = std::fs::read_to_string(&summary).unwrap();
    std::fs::write(&summary, text.replacen("\"status\"", "\"state\"", 1)).unwrap();
    let e = collect(&out, &energy_over_time).unwrap_err().to_string();
    assert!(e.contains("summary.json") && e.contains("status"), "{e}");
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
    let path = crate::common::repo("scenes/tether_sweep.ron");
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
    // The experiment is one file: its shared phases need no earlier runs,
    // so it loads (and a campaign can be emitted) before anything ran.
    let (sweep, _) = Sweep::load(&path).unwrap();
    let phases: Vec<&str> = sweep.phases.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(phases, ["initial", "reservoir"]);
}

/// A sweep with one shared phase (40 iterations of the bundled sphere with
/// κ = 3) whose runs (κ ∈ {1, 2}, 20 iterations) start from its state.
fn write_phased_sweep(dir: &Path) -> std::path::PathBuf {
    let scene = crate::common::repo("scenes/sphere.ron");
    let text = format!(
        r#"Sweep(
    name: "phased",
    scene: "{s}",
    seed: 5,
    phases: [(name: "relax", scene: "{s}", iterations: 40, set: [Kappa(3.0)])],
    conditions: [
        (name: "cont", from_phase: "relax", set: [Iterations(20)]),
        (name: "fresh", set: [Iterations(20)]),
    ],
    grid: [(name: "kappa", values: [Kappa(1.0), Kappa(2.0)])],
)"#,
        s = scene.display()
    );
    let path = dir.join("phased.ron");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn shared_phases_run_once_and_conditions_start_from_them() {
    use remembrane::workflow::slurm::slurm_campaign_script;
    use remembrane::workflow::sweep::{SweepError, phases_dir};
    let dir = tempfile::tempdir().unwrap();
    let path = write_phased_sweep(dir.path());
    let out = dir.path().join("out");
    let options = |shard, phases_only| SweepOptions {
        out: out.clone(),
        jobs: 2,
        shard,
        iterations: None,
        quiet: true,
        phases_only,
    };
    // A shard (an array task) refuses to start before the phases ran.
    match run_sweep(&path, &options(Some((0, 2)), false)) {
        Err(SweepError::Phase { phase, reason }) => {
            assert_eq!(phase, "relax");
            assert!(reason.contains("--phases-only"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
    let first = run_sweep(&path, &options(None, true)).unwrap();
    assert_eq!(first.phases.len(), 1);
    assert_eq!(first.phases[0].status, "completed");
    assert_eq!(first.completed, 0, "phases only");
    let relax = phases_dir(&out).join("relax");
    let relax_ply = std::fs::read(relax.join("final.ply")).unwrap();
    // The whole sweep keeps the phase and runs every run.
    let report = run_sweep(&path, &options(None, false)).unwrap();
    assert_eq!(report.phases[0].status, "skipped");
    assert_eq!((report.completed, report.failed.len()), (4, 0));
    assert_eq!(std::fs::read(relax.join("final.ply")).unwrap(), relax_ply);
    // `cont` runs start from the phase's final mesh, `fresh` ones from the scene's.
    let (sweep, base) = Sweep::load(&path).unwrap();
    let runs = sweep.expand();
    let cont = runs.iter().find(|r| r.condition == "cont").unwrap();
    let (_, from) = sweep.scene_for(&path, &out, &base, cont).unwrap();
    assert_eq!(from, Some(relax.join("state.json")));
    let fresh = runs.iter().find(|r| r.condition == "fresh").unwrap();
    assert_eq!(sweep.scene_for(&path, &out, &base, fresh).unwrap().1, None);
    let area = |run: &remembrane::workflow::sweep::RunSpec| -> f64 {
        let csv = std::fs::read_to_string(out.join(&run.dir).join("series.csv")).unwrap();
        let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        let k = header.iter().position(|h| *h == "area").unwrap();
        csv.lines()
            .nth(1)
            .unwrap()
            .split(',')
            .nth(k)
            .unwrap()
            .parse()
            .unwrap()
    };
    let relax_area = remembrane::io::summary::RunSummary::read(&relax)
        .unwrap()
        .last
        .area;
    assert!((area(cont) - relax_area).abs() < 1e-9 * relax_area);
    assert!((area(fresh) - relax_area).abs() > 1e-6 * relax_area);
    // A phase run under other overrides is not reused: it runs again.
    let quick = SweepOptions {
        iterations: Some(7),
        ..options(None, true)
    };
    let again = run_sweep(&path, &quick).unwrap();
    assert_eq!(again.phases[0].status, "completed");
    assert_eq!(again.phases[0].iterations, 7);
    // A campaign: phases as one job, the array after it.
    let script = slurm_campaign_script("phased", Path::new("/bin/remembrane"), &path, &out, 2);
    assert!(script.contains("--phases-only"));
    assert!(script.contains("--dependency=afterok:\"$phases\""));
    assert!(script.contains("#SBATCH --array=0-1"));
}

#[test]
fn a_condition_names_an_existing_phase() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_phased_sweep(dir.path());
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(
        &path,
        text.replace("from_phase: \"relax\"", "from_phase: \"relaxx\""),
    )
    .unwrap();
    let err = Sweep::load(&path).unwrap_err().to_string();
    assert!(
        err.contains("field `conditions[0].from_phase`: no shared phase `relaxx` (phases: relax)"),
        "{err}"
    );
}
