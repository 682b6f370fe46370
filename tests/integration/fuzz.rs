//! Fuzzing on stable Rust, in process: a seeded mutation fuzzer over every
//! input reader (scene, protocol, sweep, state.json, checkpoint, PLY, OBJ;
//! a checkpoint is also restored into a membrane), and random
//! split/merge sequences on random closed and open meshes with every
//! invariant checked.
//!
//! Mutations: byte and bit flips, truncation, splicing of two corpus files,
//! deleted and duplicated spans, numbers replaced by huge, tiny,
//! out-of-range and non-finite ones, and deep nesting. An input passes when
//! its reader returns (`Ok` or a typed error) without panicking, within
//! [`HANG`]. CI runs a reduced count; the long mode is
//!
//! ```sh
//! cargo test --release --test integration fuzz::by_hand_ -- --ignored --nocapture
//! ```
//!
//! which runs 10^6 inputs and 10^5 remesh operations and prints the counts
//! and times. `REMEMBRANE_FUZZ_SEED` changes the seed.

use remembrane::workflow::run::RunOptions;

use rand::{RngExt, SeedableRng};
use remembrane::mesh::io::{VertexScalar, read_mesh, write_obj_to, write_ply_to};
use remembrane::mesh::{ValenceRange, check_mesh, disc, docked_pair, icosphere, spherical_cap};
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

type FuzzRng = rand::rngs::Xoshiro256PlusPlus;

/// An input whose reader takes longer than this counts as a hang.
const HANG: Duration = Duration::from_secs(2);

/// The kinds of input and the reader each goes through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Kind {
    Scene,
    Protocol,
    Sweep,
    Diagram,
    State,
    Checkpoint,
    Ply,
    Obj,
}

/// The run directory whose staging directory holds the fuzzed checkpoint.
const CHECKPOINT_RUN: &str = "fuzz_run";

impl Kind {
    /// Where a mutated input of this kind is written: next to the copied
    /// scenes, so that relative paths inside it resolve as in the corpus.
    fn file(self, root: &Path) -> PathBuf {
        match self {
            Kind::Scene => root.join("scenes/fuzz_scene.ron"),
            Kind::Protocol => root.join("scenes/protocols/fuzz_protocol.ron"),
            Kind::Sweep => root.join("scenes/fuzz_sweep.ron"),
            Kind::Diagram => root.join("scenes/minimise/fuzz_diagram.ron"),
            Kind::State => root.join("fuzz_state.json"),
            Kind::Checkpoint => root
                .join(format!("{CHECKPOINT_RUN}.incomplete"))
                .join(remembrane::io::checkpoint::CHECKPOINT_FILE),
            Kind::Ply => root.join("fuzz_mesh.ply"),
            Kind::Obj => root.join("fuzz_mesh.obj"),
        }
    }

    /// Runs the reader; whether it accepted the input.
    fn read(self, path: &Path) -> bool {
        match self {
            Kind::Scene => remembrane::scene::Scene::load(path).is_ok(),
            Kind::Protocol => remembrane::workflow::protocol::Protocol::load(path).is_ok(),
            Kind::Sweep => remembrane::workflow::sweep::Sweep::parse(path).is_ok(),
            Kind::Diagram => remembrane::workflow::shape_diagram::ShapeDiagram::load(path).is_ok(),
            Kind::State => remembrane::io::state::SavedState::read(path).is_ok(),
            Kind::Checkpoint => read_checkpoint(path),
            Kind::Ply | Kind::Obj => read_mesh(path).is_ok(),
        }
    }
}

/// Reads the checkpoint at `path` and restores its world into a membrane
/// with lipid density (building its scene is the scene reader's part).
fn read_checkpoint(path: &Path) -> bool {
    let run = path.parent().unwrap().with_extension("");
    let Ok(checkpoint) = remembrane::io::checkpoint::Checkpoint::read(&run) else {
        return false;
    };
    let mut membrane =
        remembrane::mesh::membrane::Membrane::from_mesh(&icosphere(1, 1.0), true).unwrap();
    checkpoint.world.restore(&mut membrane).is_ok()
}

/// A checkpoint of a short noisy remeshing run with lipid density and
/// diffusion on a 42-vertex icosphere (stopped after 12 iterations).
fn checkpoint_corpus(root: &Path) -> Vec<u8> {
    use remembrane::workflow::run::{CheckpointSettings, RunError, drive_run, prepare_run};
    let text = r#"Scene(name: "fuzz", seed: 2, membrane: Icosphere(level: 1), lipid_density: true,
        energy: [Vin(), Bending(kappa: 1.0)],
        dynamics: (iterations: 100, temperature: 0.02, dt_max: 1e-5),
        remesh: (mode: FreeEnergy), diffusion: (rate: Finite(0.1)))"#;
    let scene_path = root.join("fuzz_run.ron");
    let scene = remembrane::scene::Scene::from_ron_str(text, &scene_path).unwrap();
    let mut options = RunOptions::quiet(root.join(CHECKPOINT_RUN));
    options.checkpoint = Some(CheckpointSettings {
        every: 5,
        scene_text: text.into(),
    });
    let mut run = prepare_run(&scene, &scene_path, &options).unwrap();
    let ticks = std::cell::Cell::new(0);
    let stop = || {
        ticks.set(ticks.get() + 1);
        ticks.get() > 12
    };
    let result = drive_run(&mut run, &scene_path, &options, Instant::now(), &stop);
    assert!(
        matches!(result, Err(RunError::Interrupted { .. })),
        "{:?}",
        result.err()
    );
    std::fs::read(Kind::Checkpoint.file(root)).unwrap()
}

/// The corpus: every bundled scene, protocol and sweep file, and a state,
/// binary and ASCII PLY and OBJ files of small meshes, closed and open (a
/// disc and a cap: no state). The scenes are copied into `root/scenes` so
/// that mutated files can sit beside them.
fn corpus(root: &Path) -> Vec<(Kind, Vec<u8>)> {
    let scenes = crate::common::repo("scenes");
    let mut out = Vec::new();
    for sub in [
        "",
        "hard",
        "scaled",
        "protocols",
        "fluctuating",
        "minimise",
        "minimise/shape_diagram",
        "fluid",
        "open",
    ] {
        let dir = scenes.join(sub);
        std::fs::create_dir_all(root.join("scenes").join(sub)).unwrap();
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "ron") {
                continue;
            }
            let bytes = std::fs::read(&path).unwrap();
            std::fs::write(
                root.join("scenes")
                    .join(sub)
                    .join(path.file_name().unwrap()),
                &bytes,
            )
            .unwrap();
            let text = String::from_utf8_lossy(&bytes);
            let kind = if remembrane::workflow::protocol::is_protocol(&text) {
                Kind::Protocol
            } else if remembrane::workflow::shape_diagram::is_shape_diagram(&text) {
                Kind::Diagram
            } else if text.contains("Sweep(") {
                Kind::Sweep
            } else {
                Kind::Scene
            };
            out.push((kind, bytes));
        }
    }
    out.push((Kind::Checkpoint, checkpoint_corpus(root)));
    let small = icosphere(1, 1.0);
    let pair = docked_pair(1);
    // Open meshes (boundary loops): a flat disc and a cap, as mesh files.
    let open_disc = disc(2.0, 1.0);
    let cap = spherical_cap(3.0, 60.0, 1.0);
    for (mesh, closed) in [
        (&small, true),
        (&pair, true),
        (&open_disc, false),
        (&cap, false),
    ] {
        let lipid = vec![1.0; mesh.positions.len()];
        if closed {
            let state = remembrane::io::state::SavedState::new("fuzz", 1, 10, 0.5, mesh, &lipid);
            out.push((Kind::State, state.to_json().into_bytes()));
        }
        let mut ply = Vec::new();
        let scalars = [VertexScalar {
            name: "density",
            values: &lipid,
        }];
        write_ply_to(&mut ply, mesh, &scalars, "fuzz corpus").unwrap();
        out.push((Kind::Ply, ply));
        let mut ascii = format!(
            "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
            mesh.positions.len(),
            mesh.faces.len()
        );
        for p in &mesh.positions {
            ascii += &format!("{} {} {}\n", p.x, p.y, p.z);
        }
        for f in &mesh.faces {
            ascii += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
        }
        out.push((Kind::Ply, ascii.into_bytes()));
        let mut obj = Vec::new();
        write_obj_to(&mut obj, mesh).unwrap();
        out.push((Kind::Obj, obj));
    }
    // Every corpus file reads as it is (else the fuzzer tests nothing).
    for (kind, bytes) in &out {
        let path = kind.file(root);
        std::fs::write(&path, bytes).unwrap();
        assert!(
            kind.read(&path),
            "corpus {kind:?} does not read:\n{}",
            String::from_utf8_lossy(bytes)
        );
    }
    out
}

/// Numbers a mutation puts in place of a number.
const NUMBERS: [&str; 16] = [
    "1e308",
    "-1e308",
    "1e400",
    "-1e400",
    "NaN",
    "inf",
    "-inf",
    "0",
    "-0",
    "1e-320",
    "18446744073709551616",
    "-9223372036854775809",
    "4294967296",
    "99999999999999999999999",
    "0.0000000000000000000001",
    "7",
];

/// Byte ranges of the numbers in `bytes`.
fn number_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i].is_ascii_digit() && (i == 0 || !bytes[i - 1].is_ascii_alphanumeric()) {
            let start = if i > 0 && bytes[i - 1] == b'-' {
                i - 1
            } else {
                i
            };
            let mut j = i;
            while j < bytes.len() && (bytes[j].is_ascii_digit() || b".eE+-".contains(&bytes[j])) {
                j += 1;
            }
            spans.push((start, j));
            i = j;
        } else {
            i += 1;
        }
    }
    spans
}

/// One mutation of `input`; `other` is a second corpus file for splicing.
fn mutate(rng: &mut FuzzRng, input: &[u8], other: &[u8]) -> Vec<u8> {
    let mut v = input.to_vec();
    let pos = |rng: &mut FuzzRng, len: usize| rng.random_range(0..=len);
    match rng.random_range(0..8u32) {
        0 => {
            // Byte flips.
            for _ in 0..rng.random_range(1..=8) {
                if !v.is_empty() {
                    let k = rng.random_range(0..v.len());
                    v[k] = rng.random();
                }
            }
        }
        1 => {
            // Bit flips.
            for _ in 0..rng.random_range(1..=8) {
                if !v.is_empty() {
                    let k = rng.random_range(0..v.len());
                    v[k] ^= 1 << rng.random_range(0..8);
                }
            }
        }
        2 => v.truncate(pos(rng, input.len())),
        3 => {
            // Splice: a prefix of one file and a suffix of another.
            let a = pos(rng, input.len());
            let b = pos(rng, other.len());
            v.truncate(a);
            v.extend_from_slice(&other[b..]);
        }
        4 => {
            // Delete or duplicate a span.
            let a = pos(rng, v.len());
            let b = (a + rng.random_range(0..64)).min(v.len());
            if rng.random_bool(0.5) {
                v.drain(a..b);
            } else {
                let span = v[a..b].to_vec();
                v.splice(a..a, span);
            }
        }
        5 | 6 => {
            // Up to three numbers replaced, the last first so that the
            // earlier spans stay where they are.
            let spans = number_spans(&v);
            if !spans.is_empty() {
                let mut picked: Vec<(usize, usize)> = (0..rng.random_range(1..=3))
                    .map(|_| spans[rng.random_range(0..spans.len())])
                    .collect();
                picked.sort_unstable();
                picked.dedup();
                for (a, b) in picked.into_iter().rev() {
                    let n = NUMBERS[rng.random_range(0..NUMBERS.len())].as_bytes();
                    v.splice(a..b, n.iter().copied());
                }
            }
        }
        _ => {
            // Deep nesting.
            let depth = [16, 200, 5_000, 100_000][rng.random_range(0..4)];
            let (open, close) = [(b'(', b')'), (b'[', b']'), (b'{', b'}')][rng.random_range(0..3)];
            let a = pos(rng, v.len());
            let mut nest = vec![open; depth];
            if rng.random_bool(0.5) {
                nest.extend(std::iter::repeat_n(close, depth));
            }
            v.splice(a..a, nest);
        }
    }
    v
}

/// What a fuzzing run saw.
#[derive(Debug, Default)]
struct FuzzReport {
    inputs: usize,
    accepted: usize,
    panics: Vec<(Kind, String, Vec<u8>)>,
    hangs: Vec<(Kind, Duration, Vec<u8>)>,
    slowest: Duration,
    elapsed: Duration,
}

fn fuzz_readers(count: usize, seed: u64) -> FuzzReport {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let corpus = corpus(root);
    let mut rng = FuzzRng::seed_from_u64(seed);
    let mut report = FuzzReport::default();
    let started = Instant::now();
    // Panics are counted, not printed.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    for _ in 0..count {
        let (kind, input) = &corpus[rng.random_range(0..corpus.len())];
        let other = &corpus[rng.random_range(0..corpus.len())].1;
        let mut bytes = mutate(&mut rng, input, other);
        if rng.random_bool(0.25) {
            bytes = mutate(&mut rng, &bytes, other);
        }
        let path = kind.file(root);
        std::fs::write(&path, &bytes).unwrap();
        let t = Instant::now();
        let outcome = std::panic::catch_unwind(AssertUnwindSafe(|| kind.read(&path)));
        let took = t.elapsed();
        report.inputs += 1;
        report.slowest = report.slowest.max(took);
        match outcome {
            Ok(accepted) => report.accepted += usize::from(accepted),
            Err(payload) => {
                let message = payload
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                report.panics.push((*kind, message, bytes.clone()));
            }
        }
        if took > HANG {
            report.hangs.push((*kind, took, bytes));
        }
    }
    std::panic::set_hook(hook);
    report.elapsed = started.elapsed();
    report
}

fn assert_clean(report: &FuzzReport) {
    for (kind, message, bytes) in report.panics.iter().take(3) {
        eprintln!(
            "PANIC in the {kind:?} reader: {message}\ninput ({} bytes): {:?}",
            bytes.len(),
            String::from_utf8_lossy(&bytes[..bytes.len().min(2000)])
        );
    }
    for (kind, took, bytes) in report.hangs.iter().take(3) {
        eprintln!(
            "HANG in the {kind:?} reader: {took:?}\ninput ({} bytes): {:?}",
            bytes.len(),
            String::from_utf8_lossy(&bytes[..bytes.len().min(2000)])
        );
    }
    assert!(report.panics.is_empty(), "{} panics", report.panics.len());
    assert!(report.hangs.is_empty(), "{} hangs", report.hangs.len());
}

fn seed() -> u64 {
    std::env::var("REMEMBRANE_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2026)
}

/// Random split/merge sequences on random meshes (jittered icospheres of
/// levels 1-3, docked pairs, and open discs and caps); after every operation the whole mesh is
/// checked (and, in debug builds, the incremental topology against a full
/// rebuild). Returns (applied, rejected).
fn fuzz_remesh(operations: usize, seed: u64) -> (usize, usize) {
    use remembrane::mesh::membrane::Membrane;
    use remembrane::remesh::{merge_edge, split_edge};
    // Wide enough for the docked pair (its seam has valence 10).
    let range = ValenceRange { min: 4, max: 10 };
    let mut rng = FuzzRng::seed_from_u64(seed);
    let (mut applied, mut rejected, mut done) = (0, 0, 0);
    while done < operations {
        let mut mesh = match rng.random_range(0..6u32) {
            0 => docked_pair(1),
            4 => disc(rng.random_range(2.0..4.0), 1.0),
            5 => spherical_cap(4.0, rng.random_range(30.0..90.0), 1.0),
            level => icosphere(level, 1.0),
        };
        mesh.jitter(rng.random_range(0.0..0.3), rng.random());
        // The mesh starts valid under the valence range the edits keep.
        let loops = check_mesh(&mesh.positions, &mesh.faces, Some(range))
            .unwrap_or_else(|err| panic!("seed {seed}: the generated mesh: {err}"))
            .boundary_loops;
        let mut m = Membrane::from_mesh(&mesh, true).unwrap();
        m.topology().unwrap();
        // A few hundred edits per mesh, then a fresh one.
        for _ in 0..rng.random_range(50..400) {
            let edges = m.cached_topology().edges.len() as u32;
            let e = rng.random_range(0..edges);
            let result = if rng.random_bool(0.5) {
                split_edge(&mut m, e, range)
            } else {
                merge_edge(&mut m, e, range)
            };
            if result.is_ok() {
                applied += 1;
            } else {
                rejected += 1;
            }
            let euler = |m: &mut Membrane| {
                let t = m.topology().unwrap();
                t.vertex_count() as i64 - t.edges.len() as i64 + t.faces.len() as i64
            };
            let before = euler(&mut m);
            let checked = m.to_mesh().unwrap();
            let report = check_mesh(&checked.positions, &checked.faces, Some(range))
                .unwrap_or_else(|err| panic!("seed {seed}, operation {done}: {err}"));
            assert_eq!(report.boundary_loops, loops, "an edit changed the loops");
            assert_eq!(
                euler(&mut m),
                before,
                "an edit changed the Euler characteristic"
            );
            done += 1;
            if done == operations {
                break;
            }
        }
    }
    (applied, rejected)
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn fuzzed_inputs_never_panic_or_hang() {
    let report = fuzz_readers(20_000, seed());
    println!(
        "{} inputs ({} accepted) in {:.1} s, slowest {:?}",
        report.inputs,
        report.accepted,
        report.elapsed.as_secs_f64(),
        report.slowest
    );
    assert_clean(&report);
    assert!(report.accepted > 0 && report.accepted < report.inputs);
}

#[test]
fn random_remesh_operations_keep_every_invariant() {
    let (applied, rejected) = fuzz_remesh(3_000, seed());
    println!("remesh: {applied} applied, {rejected} rejected");
    assert!(applied > 500, "{applied} applied");
}

/// The long mode: 10^6 inputs and 10^5 remesh operations.
#[test]
#[ignore = "long fuzzing run: cargo test --release --test integration fuzz::by_hand_ -- --ignored --nocapture"]
fn by_hand_long_fuzzing_run() {
    let report = fuzz_readers(1_000_000, seed());
    println!(
        "readers: {} inputs ({} accepted) in {:.1} s, slowest {:?}, {} panics, {} hangs",
        report.inputs,
        report.accepted,
        report.elapsed.as_secs_f64(),
        report.slowest,
        report.panics.len(),
        report.hangs.len()
    );
    assert_clean(&report);
    let started = Instant::now();
    let (applied, rejected) = fuzz_remesh(100_000, seed());
    println!(
        "remesh: 100000 operations ({applied} applied, {rejected} rejected) in {:.1} s, every invariant held",
        started.elapsed().as_secs_f64()
    );
}
