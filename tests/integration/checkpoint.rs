//! Checkpoint and resume: a run killed with SIGKILL at random moments,
//! three times, and resumed each time with `remembrane run --resume`,
//! writes the same bytes as the same run left alone (every file;
//! `summary.json` without its wall-clock timings). The scene exercises
//! every piece of carried state: thermal noise, free-energy remeshing (hecs'
//! free list decides the handles of new entities), lipid density with
//! finite diffusion, a control point moved on a simulated-time schedule,
//! a named control point's force and a tube radius normalised by its first
//! frame, frames by simulated time.

use crate::common;

use rand::{RngExt, SeedableRng};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_remembrane");

/// About 1500 iterations with a few hundred remesh events.
const SCENE: &str = r#"Scene(
    name: "checkpointed",
    seed: 3,
    membrane: Icosphere(level: 3, mean_edge_length: 1.0, jitter: 6.6e-4),
    valence: (min: 5, max: 8),
    lipid_density: true,
    energy: [
        Vin(),
        Bending(kappa: 5.0),
        Volume(k: 4.0, target: Absolute(1223.0)),
        LocalTension(k: 12.0, target_area: Absolute(553.0)),
        Springs(stiffness: 5.0),
    ],
    penalty_smoothing: 4,
    control_points: [
        (position: (-10.0, 10.0, 0.0), name: Some("puller")),
        (position: (4.67, -4.67, 0.0)),
    ],
    control_point_schedule: [
        (when: EveryTime(interval: 2.5e-5), points: [0], change: MoveBy(-0.1, 0.1, 0.0)),
    ],
    tube_radius: [
        (name: "left", first: (-7.5, 7.5, 0.0), step: (-0.5, 0.5, 0.0), planes: 5),
    ],
    dynamics: (max_displacement: 0.01, iterations: 1500, temperature: 0.05, frame_time: 2.5e-5),
    remesh: (mode: FreeEnergy),
    diffusion: (rate: Finite(0.1), sweeps: 20),
)
"#;

fn scene_file(dir: &Path) -> PathBuf {
    let path = dir.join("checkpointed.ron");
    std::fs::write(&path, SCENE).unwrap();
    path
}

fn remembrane(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().unwrap()
}

fn spawn(args: &[&str]) -> Child {
    Command::new(BIN)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

/// Runs `args` to completion; it must succeed.
fn run_ok(args: &[&str]) {
    let out = remembrane(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Two runs' files (by relative path) are the same bytes.
fn assert_same_files(
    a: &std::collections::BTreeMap<PathBuf, Vec<u8>>,
    b: &std::collections::BTreeMap<PathBuf, Vec<u8>>,
) {
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "the same files"
    );
    for (file, bytes) in a {
        assert!(bytes == &b[file], "{} differs", file.display());
    }
}

/// The iteration of the checkpoint in `staging`, if one can be read.
fn checkpoint_iteration(staging: &Path) -> Option<u64> {
    let text = std::fs::read_to_string(staging.join("checkpoint.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["iteration"].as_u64()
}

/// Runs `scene` whole, then again killed (SIGKILL) three times at random
/// moments after a checkpoint (every `every` iterations) and resumed on
/// 2, 3 and 1 threads; asserts both runs wrote the same bytes. Returns the
/// killed run's directory (in `tmp`).
fn killed_three_times_and_resumed(tmp: &Path, scene: &str, every: &str) -> PathBuf {
    let path = tmp.join("checkpointed.ron");
    std::fs::write(&path, scene).unwrap();
    let scene = path.to_str().unwrap();
    let whole = tmp.join("whole");
    run_ok(&["run", scene, "--out", whole.to_str().unwrap(), "--quiet"]);

    let killed = tmp.join("killed");
    let dir = killed.to_str().unwrap();
    let staging = tmp.join("killed.incomplete");
    let seed = std::env::var("REMEMBRANE_KILL_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2026u64);
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut child = spawn(&[
        "run",
        scene,
        "--out",
        dir,
        "--quiet",
        "--checkpoint-every",
        every,
        "--threads",
        "1",
    ]);
    let mut last = None;
    let mut at = Vec::new();
    for kill in 0..3 {
        // Wait for a checkpoint newer than the one this segment started
        // from, then kill at a random moment after it (possibly while a
        // frame or the next checkpoint is being written).
        let waited = Instant::now();
        loop {
            let now = checkpoint_iteration(&staging);
            if now.is_some() && now > last {
                break;
            }
            assert!(
                child.try_wait().unwrap().is_none(),
                "kill {kill}: the run ended before a new checkpoint (seed {seed})"
            );
            assert!(waited.elapsed() < Duration::from_secs(300));
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(Duration::from_millis(rng.random_range(0..400)));
        assert!(
            child.try_wait().unwrap().is_none(),
            "kill {kill}: the run ended before it could be killed (seed {seed}); make the scene longer"
        );
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        last = checkpoint_iteration(&staging);
        at.push(last.unwrap());
        assert!(!killed.exists(), "a killed run must not look like a result");
        // Resume on another thread count: results do not depend on it.
        let threads = ["2", "3", "1"][kill];
        child = spawn(&["run", "--resume", dir, "--quiet", "--threads", threads]);
    }
    let status = child.wait().unwrap();
    assert!(status.success(), "the last resume failed (seed {seed})");
    assert!(!staging.exists());
    assert!(!killed.join("checkpoint.json").exists());
    eprintln!("killed after the checkpoints of iterations {at:?} (seed {seed})");

    assert_same_files(
        &common::run_contents(&whole),
        &common::run_contents(&killed),
    );
    killed
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_run_killed_three_times_and_resumed_writes_the_same_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let killed = killed_three_times_and_resumed(tmp.path(), SCENE, "25");
    let summary = crate::common::summary(&killed);
    assert!(summary.remesh.events > 50, "the scene remeshes");
}

/// The fluid red blood cell with one protein species, minimised: the
/// proteins' amounts on the vertices (through remeshing and flips), the
/// species' status and FIRE's state are all carried by a checkpoint.
const SPECIES_SCENE: &str = r#"Scene(
    name: "checkpointed_species",
    membrane: Ellipsoid(level: 3, semi_axes: (6.864, 6.864, 6.178)),
    model: Fluid(),
    energy: [
        Vin(form: Exact),
        Bending(kappa: 5.0),
    ],
    constraints: (area: Absolute(553.0), volume: Reduced(0.6)),
    dynamics: (
        method: Minimise(force_tolerance: 1e-6, preconditioner: Sobolev()),
        iterations: 1200,
        frames: 10,
    ),
    remesh: (mode: FreeEnergy),
    species: (
        species: [(
            name: "bar",
            area_per_protein: 0.05,
            curvature_coupling: 1.0,
            initial: Fraction(0.2),
        )],
    ),
)
"#;

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_minimisation_with_species_killed_three_times_and_resumed_writes_the_same_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let killed = killed_three_times_and_resumed(tmp.path(), SPECIES_SCENE, "25");
    let summary = crate::common::summary(&killed);
    let status: remembrane::species::model::SpeciesStatus =
        summary.section("species").unwrap().unwrap();
    assert!(status.relaxations > 1000, "{status:?}");
    assert!(summary.remesh.events > 0, "the scene remeshes");
}

/// A thermal vesicle (Metropolis flips) whose protein species moves with
/// noise: the amounts, the species' status and the count of the noise's
/// draws are carried by a checkpoint.
const SPECIES_DYNAMICS_SCENE: &str = r#"Scene(
    name: "checkpointed_species_dynamics",
    membrane: Icosphere(level: 3, mean_edge_length: 1.0),
    energy: [
        Vin(v0: 4.0, far_barrier: (1.5, 1.75)),
        Bending(kappa: 1.5),
        Volume(k: 1.0, target: OfInitial(1.0)),
        Area(k: 200.0, target: OfInitial(1.0)),
    ],
    penalty_smoothing: 0,
    dynamics: (
        temperature: 0.1,
        dt_max: 1e-6,
        vin_step_limit: false,
        iterations: 3000,
        frames: 10,
    ),
    edge_flips: (attempts_per_edge: 0.01, edge_range: (0.7, 1.5)),
    species: (
        species: [(
            name: "bar",
            area_per_protein: 0.01,
            curvature_coupling: 1.0,
            initial: Fraction(0.2),
            mobility: 200.0,
        )],
    ),
)
"#;

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn thermal_dynamics_with_species_killed_three_times_and_resumed_writes_the_same_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let killed = killed_three_times_and_resumed(tmp.path(), SPECIES_DYNAMICS_SCENE, "200");
    let summary = crate::common::summary(&killed);
    let status: remembrane::species::model::SpeciesStatus =
        summary.section("species").unwrap().unwrap();
    assert!(status.transport_steps >= 3000, "{status:?}");
    let (n0, n) = (status.initial_counts[0], status.counts[0]);
    assert!((n - n0).abs() <= 1e-12 * n0, "{n0} → {n}");
}

#[test]
fn resuming_what_cannot_be_resumed_fails_cleanly() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = scene_file(tmp.path());
    let scene = scene.to_str().unwrap();

    // No such run.
    let missing = tmp.path().join("missing");
    let out = remembrane(&["run", "--resume", missing.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("checkpoint.json") && err.contains("staging"),
        "{err}"
    );

    // Options that would change the run.
    let out = remembrane(&["run", "--resume", "x", "--seed", "4"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--seed cannot be given"));
    let out = remembrane(&["run", scene, "--resume", "x"]);
    assert_eq!(out.status.code(), Some(2));
    let out = remembrane(&["run", scene, "--checkpoint-every", "0"]);
    assert_eq!(out.status.code(), Some(2));

    // A finished run.
    let done = tmp.path().join("done");
    let done_dir = done.to_str().unwrap();
    let out = remembrane(&[
        "run",
        scene,
        "--out",
        done_dir,
        "--quiet",
        "--iterations",
        "30",
        "--checkpoint-every",
        "10",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!done.join("checkpoint.json").exists());
    let out = remembrane(&["run", "--resume", done_dir]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("has ended"));

    // A damaged checkpoint: the error names the file and the run directory
    // is left as it was.
    let staging = tmp.path().join("cut.incomplete");
    std::fs::create_dir_all(staging.join("frames")).unwrap();
    let cp = staging.join("checkpoint.json");
    std::fs::write(&cp, "{\"format\": \"remembrane-checkpoint-1\", \"engine\"").unwrap();
    let out = remembrane(&["run", "--resume", tmp.path().join("cut").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cut.incomplete/checkpoint.json") && err.contains("not a checkpoint"),
        "{err}"
    );
    assert!(cp.exists());

    // A scene whose mesh file changed since the checkpoint is refused.
    let mesh_scene = tmp.path().join("mesh.ron");
    let mesh = tmp.path().join("ball.obj");
    write_icosahedron(&mesh, 1.0);
    std::fs::write(
        &mesh_scene,
        r#"Scene(name: "mesh", membrane: File(path: "ball.obj", scale: 1.0),
                energy: [Bending(kappa: 1.0)], dynamics: (iterations: 100000))"#,
    )
    .unwrap();
    let run = tmp.path().join("mesh_run");
    let mut child = spawn(&[
        "run",
        mesh_scene.to_str().unwrap(),
        "--out",
        run.to_str().unwrap(),
        "--checkpoint-every",
        "1",
        "--quiet",
    ]);
    let staging = tmp.path().join("mesh_run.incomplete");
    while checkpoint_iteration(&staging).is_none_or(|i| i < 1) {
        std::thread::sleep(Duration::from_millis(1));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!run.exists(), "killed long before its 10^5 iterations");
    write_icosahedron(&mesh, 1.5);
    let out = remembrane(&["run", "--resume", run.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("has changed"), "{err}");
}

/// An icosahedron with edges of `edge` (l̄) as an OBJ file.
fn write_icosahedron(path: &Path, edge: f64) {
    remembrane::mesh::io::write_mesh(path, &remembrane::mesh::icosphere(0, edge)).unwrap();
}

/// A protocol of two phases (the second starts from the first's state),
/// killed once in each phase and resumed, writes what it writes left alone
/// (`protocol.json` without the phases' wall times).
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_protocol_killed_in_each_phase_and_resumed_writes_the_same_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    scene_file(tmp.path());
    let protocol = tmp.path().join("protocol.ron");
    std::fs::write(
        &protocol,
        r#"Protocol(
    name: "two_phases",
    phases: [
        (name: "first", scene: "checkpointed.ron", iterations: 700),
        (name: "second", scene: "checkpointed.ron", start: Previous, iterations: 700,
         set: [Kappa(4.0), DiffusionRate(0.2)]),
    ],
)"#,
    )
    .unwrap();
    let protocol = protocol.to_str().unwrap();
    let whole = tmp.path().join("whole");
    run_ok(&["run", protocol, "--out", whole.to_str().unwrap(), "--quiet"]);

    let killed = tmp.path().join("killed");
    let dir = killed.to_str().unwrap();
    let staging = tmp.path().join("killed.incomplete");
    let mut child = spawn(&[
        "run",
        protocol,
        "--out",
        dir,
        "--quiet",
        "--checkpoint-every",
        "25",
    ]);
    for phase in ["first", "second"] {
        let phase_staging = staging.join(format!("{phase}.incomplete"));
        let waited = Instant::now();
        while checkpoint_iteration(&phase_staging).is_none_or(|i| i < 100) {
            assert!(
                child.try_wait().unwrap().is_none(),
                "the protocol ended before phase {phase} could be killed"
            );
            assert!(waited.elapsed() < Duration::from_secs(300));
            std::thread::sleep(Duration::from_millis(2));
        }
        child.kill().unwrap();
        child.wait().unwrap();
        assert!(!killed.exists());
        child = spawn(&["run", "--resume", dir, "--quiet", "--threads", "2"]);
    }
    assert!(child.wait().unwrap().success());
    let out = remembrane(&["run", "--resume", dir]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("has ended"));

    let without_wall_times = |dir: &Path| {
        let mut files = common::run_contents(dir);
        let key = PathBuf::from("protocol.json");
        let mut v: serde_json::Value = serde_json::from_slice(&files[&key]).unwrap();
        for phase in v["phases"].as_array_mut().unwrap() {
            phase.as_object_mut().unwrap().remove("wall_time_s");
        }
        files.insert(key, serde_json::to_vec(&v).unwrap());
        files
    };
    assert_same_files(&without_wall_times(&whole), &without_wall_times(&killed));
}
