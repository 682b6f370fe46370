//! The command line: exit codes, output, and clean errors (no panics).

use remembrane::io::summary::RunStatus;
use std::path::Path;
use std::process::{Command, Output};

fn remembrane(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_remembrane"))
        .args(args)
        .output()
        .unwrap()
}

fn scene(name: &str) -> String {
    crate::common::scene(name).to_string_lossy().into_owned()
}

#[test]
fn bundled_scenes_check_and_evaluate() {
    let dir = crate::common::repo("scenes");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".ron") && !n.ends_with("_sweep.ron"))
        .collect();
    names.sort();
    assert!(names.len() >= 9, "{names:?}");
    for name in &names {
        let out = remembrane(&["check", &scene(name)]);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let out = remembrane(&["energy", &scene(name), "--json"]);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(json["total_energy"].as_f64().unwrap().is_finite());
    }
}

#[test]
fn energy_reports_the_sphere_and_writes_forces() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("f.csv");
    let out = remembrane(&[
        "energy",
        &scene("sphere.ron"),
        "--json",
        "--forces",
        csv.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!((json["energies"][0]["energy"].as_f64().unwrap() - 25.0136).abs() < 1e-3);
    assert_eq!(json["vertices"], 642);
    assert_eq!(json["quality"]["valence_histogram"]["5"], 12);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "vertex,x,y,z,bending_fx,bending_fy,bending_fz,total_fx,total_fy,total_fz"
    );
    assert_eq!(lines.count(), 642);
}

#[test]
fn bad_input_exits_non_zero_with_a_clean_message() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.ron");
    std::fs::write(
        &bad,
        "Scene(\n  membrane: Icosphere(level: 2),\n  energy: [Bending(kappa: -1.0)],\n)",
    )
    .unwrap();
    let missing = dir.path().join("absent.ron");
    for args in [
        vec!["energy", bad.to_str().unwrap()],
        vec!["check", bad.to_str().unwrap()],
        vec!["check", missing.to_str().unwrap()],
    ] {
        let out = remembrane(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: "), "{err}");
        assert!(
            !err.contains("panicked") && !err.contains("backtrace"),
            "{err}"
        );
        assert!(out.stdout.is_empty(), "no partial output on error");
    }
    let out = remembrane(&["energy", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.ron:3:") && err.contains("energy[0].Bending.kappa"),
        "{err}"
    );
}

#[test]
fn forces_file_is_not_written_on_error() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.ron");
    std::fs::write(
        &bad,
        "Scene(membrane: Icosphere(level: 99), energy: [Bending()])",
    )
    .unwrap();
    let csv = dir.path().join("f.csv");
    let out = remembrane(&[
        "energy",
        bad.to_str().unwrap(),
        "--forces",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!csv.exists());
}

#[test]
fn run_without_a_scene_uses_the_bundled_default_and_writes_a_complete_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rbc");
    let out_s = out.to_str().unwrap();
    let result = remembrane(&[
        "run",
        "--iterations",
        "30",
        "--frames",
        "2",
        "--out",
        out_s,
        "--quiet",
    ]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    assert!(result.stderr.is_empty(), "--quiet prints nothing");
    for f in [
        "summary.json",
        "series.csv",
        "run.pvd",
        "final.ply",
        "final.png",
        "frames/frame_000000.vtp",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let summary = crate::common::summary(&out);
    assert_eq!(summary.last.scene, "red_blood_cell");
    assert_eq!(summary.status, RunStatus::Completed);
    assert_eq!(summary.iterations, 30);
    // The same run again into the same directory is refused (exit 2), and
    // --overwrite replaces it.
    let again = remembrane(&["run", "--iterations", "30", "--out", out_s, "--quiet"]);
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("already exists"));
    let replaced = remembrane(&[
        "run",
        "--iterations",
        "10",
        "--out",
        out_s,
        "--quiet",
        "--overwrite",
    ]);
    assert!(replaced.status.success());
    // Same seed, same output, whatever the thread count.
    let other = dir.path().join("rbc2");
    let r2 = remembrane(&[
        "run",
        "--iterations",
        "10",
        "--out",
        other.to_str().unwrap(),
        "--quiet",
        "--threads",
        "1",
    ]);
    assert!(r2.status.success());
    assert_eq!(
        std::fs::read(out.join("final.ply")).unwrap(),
        std::fs::read(other.join("final.ply")).unwrap()
    );
}

#[test]
fn run_rejects_bad_scenes_and_flags_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.ron");
    std::fs::write(
        &bad,
        "Scene(membrane: Icosphere(level: 2), energy: [Bending()], remesh: (mode: FreeEnergy))",
    )
    .unwrap();
    let out = remembrane(&[
        "run",
        bad.to_str().unwrap(),
        "--out",
        dir.path().join("o").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("bad.ron") && err.contains("remesh.mode") && err.contains("Vin"),
        "{err}"
    );
    assert!(!dir.path().join("o").exists() && !dir.path().join("o.incomplete").exists());
}

/// `--check-invariants` and `--no-check-invariants` override the build's
/// default (on in the debug builds the tests run, off in release); given
/// together they are refused before anything is written.
#[test]
fn invariant_checks_follow_the_flags_over_the_builds_default() {
    use remembrane::engine::simulation::CheckInvariants;
    use remembrane::workflow::run::{RunOptions, prepare_run};
    let path = crate::common::scene("sphere.ron");
    let sphere = remembrane::scene::Scene::load(&path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for (given, checks) in [
        (None, cfg!(debug_assertions)),
        (Some(true), true),
        (Some(false), false),
    ] {
        let mut options = RunOptions::quiet(dir.path().join("run"));
        options.check_invariants = given;
        let run = prepare_run(&sphere, &path, &options).unwrap();
        assert_eq!(run.sim.resource::<CheckInvariants>().0, checks, "{given:?}");
    }
    let out = dir.path().join("both");
    let both = remembrane(&[
        "run",
        &scene("sphere.ron"),
        "--out",
        out.to_str().unwrap(),
        "--check-invariants",
        "--no-check-invariants",
    ]);
    let err = String::from_utf8_lossy(&both.stderr);
    assert_eq!(both.status.code(), Some(2), "{err}");
    assert!(err.contains("--no-check-invariants"), "{err}");
    assert!(!out.exists() && !dir.path().join("both.incomplete").exists());
}

#[test]
fn compare_runs_both_scenes_and_writes_table_csv_and_chart() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cmp");
    let result = remembrane(&[
        "compare",
        &scene("vesicle_fusion.ron"),
        &scene("fusion_geometric.ron"),
        "--iterations",
        "150",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let table = String::from_utf8_lossy(&result.stdout);
    assert!(
        table.contains("vesicle_fusion")
            && table.contains("fusion_geometric")
            && table.contains("ratio"),
        "{table}"
    );
    let csv = std::fs::read_to_string(out.join("comparison.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3);
    let png = std::fs::read(out.join("comparison.png")).unwrap();
    let reader = png::Decoder::new(std::io::Cursor::new(png))
        .read_info()
        .unwrap();
    assert_eq!((reader.info().width, reader.info().height), (800, 520));
    for name in ["vesicle_fusion", "fusion_geometric"] {
        assert!(out.join(name).join("summary.json").exists());
        assert!(out.join(name).join("events.vtp").exists());
    }
}

/// Commands the README shows that this test does not run, each with what
/// runs it.
const README_COMMANDS_RUN_ELSEWHERE: [(&str, &str); 4] = [
    ("cargo test", ".ci/run: cargo test --locked"),
    (
        "cargo run --release -p bar_domain -- run examples/bar_domain/scenes/bud.ron",
        "examples/bar_domain/tests/bud.rs: the same arguments through main_with, 2000 iterations",
    ),
    (
        "pip install \"./python[test,interop,tutorial]\"",
        ".ci/run: pip install \"./python[test,interop,tutorial]\" (into a fresh venv)",
    ),
    (
        "python python/examples/tutorial.py",
        ".ci/run: python python/examples/tutorial.py target/python-tutorial",
    ),
];

/// The commands of the README's `sh` blocks, one per line (comments and
/// continuation lines joined).
fn readme_shell_commands(readme: &str) -> Vec<String> {
    let mut commands = Vec::new();
    let mut in_sh = false;
    let mut pending = String::new();
    for line in readme.lines() {
        let trimmed = line.trim();
        if let Some(tag) = trimmed.strip_prefix("```") {
            in_sh = !in_sh && tag == "sh";
            continue;
        }
        if !in_sh {
            continue;
        }
        let command = trimmed.split(" #").next().unwrap().trim();
        if command.is_empty() || command.starts_with('#') {
            continue;
        }
        match command.strip_suffix('\\') {
            Some(part) => pending.push_str(part),
            None => {
                pending.push_str(command);
                commands.push(pending.split_whitespace().collect::<Vec<_>>().join(" "));
                pending.clear();
            }
        }
    }
    commands
}

/// Every shell command the README shows is run: the `remembrane` ones and
/// `cargo run --release -- ...` (the same binary) here, as shown but with
/// tiny iteration counts, from a scratch directory that sees the
/// repository's scenes, in order (a later command may read an earlier one's
/// output); the others by what README_COMMANDS_RUN_ELSEWHERE names.
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn readme_commands_run() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let commands = readme_shell_commands(&readme);
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(root.join("scenes"), dir.path().join("scenes")).unwrap();
    let mut ran = 0;
    for command in &commands {
        if README_COMMANDS_RUN_ELSEWHERE
            .iter()
            .any(|(shown, _)| shown == command)
        {
            continue;
        }
        let rest = command
            .strip_prefix("remembrane ")
            .or_else(|| command.strip_prefix("cargo run --release -- "))
            .or_else(|| (command == "cargo run --release --").then_some(""))
            .unwrap_or_else(|| {
                panic!(
                    "the README shows `{command}`, which nothing runs: run it here or list \
                     it in README_COMMANDS_RUN_ELSEWHERE with what runs it"
                )
            });
        let mut args: Vec<&str> = rest.split_whitespace().collect();
        assert!(
            args.iter().all(|a| !a.contains(['"', '\'', '$', '*'])),
            "`{command}`: no shell syntax in the README's remembrane commands"
        );
        match args.first().copied() {
            Some("run") => args.extend(["--iterations", "20", "--frames", "1"]),
            Some("compare") | Some("sweep") => args.extend(["--iterations", "20"]),
            _ => {}
        }
        let out = Command::new(env!("CARGO_BIN_EXE_remembrane"))
            .args(&args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "`{command}` (run as remembrane {}): {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
        ran += 1;
    }
    assert!(ran >= 2, "the README's commands: {commands:?}");
}
