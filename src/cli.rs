//! The `remembrane` command line as a library: [`main_with`] gives a
//! user's binary the whole CLI (run, check, energy, compare, sweep,
//! collect) with its own plugins.
//!
//! ```no_run
//! use remembrane::scene::registry::PluginRegistry;
//!
//! fn main() -> std::process::ExitCode {
//!     let mut plugins = PluginRegistry::new();
//!     // plugins.register_term::<MyParams, _>("my_term", |p, b| { ... });
//!     remembrane::cli::main_with(plugins)
//! }
//! ```

use crate::io::report::{EnergyReport, forces_csv};
use crate::scene::Scene;
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Writes a line to standard output; a closed pipe (`remembrane ... | head`)
/// ends the process quietly instead of panicking.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($arg)*) {
            stdout_failed(e);
        }
    }};
}

/// [`say!`] without the newline.
macro_rules! say_raw {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = write!(std::io::stdout(), $($arg)*) {
            stdout_failed(e);
        }
    }};
}

/// Standard output could not be written: a closed pipe is a normal end (the
/// reader has what it wanted); anything else is reported.
fn stdout_failed(e: std::io::Error) {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        std::process::exit(0);
    }
    eprintln!("error: cannot write to standard output: {e}");
    std::process::exit(1);
}

/// Membrane simulation with free-energy-controlled remeshing.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene and write frames, series, summary and the final mesh.
    /// Without a scene, runs the bundled red-blood-cell scene.
    Run {
        /// Scene file (RON); default: the bundled red_blood_cell.ron.
        scene: Option<PathBuf>,
        #[command(flatten)]
        args: RunArgs,
    },
    /// Run two remeshing scenes (e.g. free-energy vs geometric) and compare
    /// their remesh events and σ(|r|) (paper Fig 3C/D): a table, CSV and PNG.
    Compare {
        /// First scene (e.g. scenes/vesicle_fusion.ron).
        first: PathBuf,
        /// Second scene (e.g. scenes/fusion_geometric.ron).
        second: PathBuf,
        /// Iterations for both runs (overrides the scenes').
        #[arg(long)]
        iterations: Option<u64>,
        /// Output directory (default out/compare-<first>-<second>); each run
        /// goes into a subfolder named after its scene.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Replace the output directory if it exists.
        #[arg(long)]
        overwrite: bool,
        /// Seed for both runs (overrides the scenes').
        #[arg(long)]
        seed: Option<u64>,
        /// No progress output.
        #[arg(long)]
        quiet: bool,
    },
    /// Run a parameter sweep (base scene × conditions × grid × repeats),
    /// resumable, in parallel, or one shard of it; or print a Slurm
    /// job-array script that runs it.
    Sweep {
        /// Sweep file (RON), e.g. sweeps/tether.ron.
        sweep: PathBuf,
        /// Output directory (default out/<sweep name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Runs at once (default: number of cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// Run only the runs with index ≡ I (mod N), e.g. 3/8.
        #[arg(long, value_name = "I/N")]
        shard: Option<String>,
        /// Override every run's iterations (quick trials).
        #[arg(long)]
        iterations: Option<u64>,
        /// Print an sbatch job-array script for this sweep instead of running.
        #[arg(long)]
        emit_slurm: bool,
        /// Array tasks of the emitted script (default: one per run).
        #[arg(long)]
        tasks: Option<usize>,
        /// Run only the sweep's shared phases (the first job of a campaign).
        #[arg(long)]
        phases_only: bool,
        /// No per-run progress lines.
        #[arg(long)]
        quiet: bool,
    },
    /// Aggregate a sweep's runs: 4th-order fit of one series.csv column
    /// against another per run, mean ± sd per condition and grid point
    /// (paper Fig 5E/F) as CSV tables and PNG charts in DIR.
    Collect {
        /// Sweep output directory (with sweep.json).
        dir: PathBuf,
        /// Column on the x axis.
        #[arg(long, default_value = "radius_left_norm")]
        x: String,
        /// Column on the y axis.
        #[arg(long, default_value = "radius_right_norm")]
        y: String,
        /// Rows of each series.csv used (from the first).
        #[arg(long, default_value_t = 31)]
        frames: usize,
        /// Succeed even if some runs have no results yet.
        #[arg(long)]
        partial: bool,
    },
    /// The vesicle shape diagram: walk each branch of a ShapeDiagram file
    /// down its reduced volumes with the minimiser, each point from the one
    /// before, on each mesh; write diagram.csv, diagram.md, diagram.json and
    /// diagram.png (E_b/8πκ against v beside the axisymmetric solver's
    /// curves) in OUT and print the table. `remembrane run FILE` does the
    /// same with the defaults.
    Diagram {
        /// Shape-diagram file (RON), e.g. scenes/minimise/shape_diagram.ron.
        diagram: PathBuf,
        /// Output directory (default out/<diagram name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Replace the output directory if it exists.
        #[arg(long)]
        overwrite: bool,
        /// Walk only these meshes (labels, comma-separated).
        #[arg(long, value_delimiter = ',')]
        meshes: Option<Vec<String>>,
        /// Override every point's iteration cap (quick trials).
        #[arg(long)]
        iterations: Option<u64>,
        /// Worker threads (default: all cores). Results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
        /// No per-point lines and no table.
        #[arg(long)]
        quiet: bool,
    },
    /// Speed against error: run a study's ladder of settings on reference
    /// problems with independent answers (resumable), then write study.csv,
    /// study.md, study.json and error-vs-cost / convergence charts in OUT
    /// and print the tables.
    Study {
        /// Study file (RON), e.g. scenes/studies/accuracy.ron.
        study: PathBuf,
        /// Output directory (default out/<study name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Cases at once (default 1: wall times are comparable only when
        /// cases do not share the cores).
        #[arg(long, default_value_t = 1)]
        jobs: usize,
        /// Only the rungs each problem lists in `quick` (the CI ladder).
        #[arg(long)]
        quick: bool,
        /// Do not run the study's peer engines.
        #[arg(long)]
        no_peers: bool,
        /// No per-case progress lines.
        #[arg(long)]
        quiet: bool,
    },
    /// Flicker spectrum of a fluctuating quasi-spherical vesicle run: its
    /// frames' shapes in spherical harmonics, ⟨|u_lm|²⟩ by l after an
    /// equilibration time, and the Helfrich fit of κ and σ with block
    /// error bars (spectrum.csv, spectrum_fit.json, spectrum.png in DIR).
    Spectrum {
        /// Run directory (with summary.json and frames/).
        dir: PathBuf,
        /// Frames before this simulated time are discarded (s).
        #[arg(long, default_value_t = 0.0)]
        equilibration: f64,
        /// Lowest l fitted.
        #[arg(long, default_value_t = 2)]
        l_min: usize,
        /// Highest l fitted.
        #[arg(long, default_value_t = 12)]
        l_max: usize,
        /// Blocks of consecutive frames for the error bars.
        #[arg(long, default_value_t = 10)]
        blocks: usize,
        /// k_BT (Ē; default: the run's scene's temperature).
        #[arg(long)]
        kbt: Option<f64>,
        /// Input κ to draw (Ē; default: the run's scene's Bending kappa).
        #[arg(long)]
        kappa: Option<f64>,
        /// Fit against the discrete bending energy's own stiffness against
        /// each mode (measured on the last frame's mesh) instead of the
        /// continuum's: the cotangent energy is softer for modes a few edges
        /// long, which a continuum fit reads as a lower κ.
        #[arg(long)]
        discrete: bool,
    },
    /// Validate a scene and print what it declares.
    Check {
        /// Scene file (RON).
        scene: PathBuf,
    },
    /// Evaluate the scene's initial state: energies per term, area, volume,
    /// reduced volume and mesh quality.
    Energy {
        /// Scene file (RON).
        scene: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Also write per-vertex forces (each term and the total) as CSV.
        #[arg(long, value_name = "FILE.csv")]
        forces: Option<PathBuf>,
    },
}

/// The scene `remembrane run` uses when none is given.
const BUNDLED_SCENE: &str = include_str!("../scenes/red_blood_cell.ron");
const BUNDLED_SCENE_NAME: &str = "bundled:red_blood_cell.ron";

/// Runs the CLI on the process arguments with `registry`'s plugins
/// available to every scene (installed as the process default registry).
pub fn main_with(registry: crate::scene::registry::PluginRegistry) -> ExitCode {
    main_with_args(registry, std::env::args_os())
}

/// [`main_with`] on explicit arguments (the first is the program name).
pub fn main_with_args<I, T>(registry: crate::scene::registry::PluginRegistry, args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    registry.install_as_default();
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    match cli.command {
        Command::Run { scene, args } => run_command(scene.as_deref(), args),
        Command::Compare {
            first,
            second,
            iterations,
            out,
            overwrite,
            seed,
            quiet,
        } => compare_command(&first, &second, iterations, out, overwrite, seed, quiet),
        Command::Sweep {
            sweep,
            out,
            jobs,
            shard,
            iterations,
            emit_slurm,
            tasks,
            phases_only,
            quiet,
        } => sweep_command(
            &sweep,
            SweepArgs {
                out,
                jobs,
                shard,
                iterations,
                emit_slurm,
                tasks,
                phases_only,
                quiet,
            },
        ),
        Command::Collect {
            dir,
            x,
            y,
            frames,
            partial,
        } => collect_command(&dir, x, y, frames, partial),
        Command::Study {
            study,
            out,
            jobs,
            quick,
            no_peers,
            quiet,
        } => study_command(&study, out, jobs, quick, no_peers, quiet),
        Command::Diagram {
            diagram,
            out,
            overwrite,
            meshes,
            iterations,
            threads,
            quiet,
        } => diagram_command(
            &diagram,
            out,
            crate::workflow::shape_diagram::DiagramOptions {
                overwrite,
                meshes,
                iterations,
                progress: !quiet,
            },
            threads,
        ),
        other => match run(other) {
            Ok(()) => ExitCode::SUCCESS,
            Err(message) => {
                eprintln!("error: {message}");
                ExitCode::from(2)
            }
        },
    }
}

/// Options of `remembrane run`.
#[derive(clap::Args)]
struct RunArgs {
    /// Output directory (default: out/<scene name>, or out/<name>.N if
    /// that exists).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    overwrite: bool,
    /// Seed (overrides the scene's).
    #[arg(long)]
    seed: Option<u64>,
    /// Iterations (overrides the scene's).
    #[arg(long)]
    iterations: Option<u64>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// Frames to write (overrides the scene's).
    #[arg(long)]
    frames: Option<u32>,
    /// No progress output.
    #[arg(long)]
    quiet: bool,
    /// Check every mesh invariant after each remesh edit (debug mode; slow).
    #[arg(long)]
    check_invariants: bool,
    /// Start from the saved state of an earlier run (its state.json)
    /// instead of the scene's membrane.
    #[arg(long, value_name = "STATE.json")]
    from: Option<PathBuf>,
    /// Write a checkpoint every N iterations (DIR.incomplete/checkpoint.json,
    /// atomically), from which `--resume DIR` continues a killed run with
    /// the same outputs, byte for byte.
    #[arg(long, value_name = "N")]
    checkpoint_every: Option<u64>,
    /// Continue the killed or interrupted run whose --out was DIR from its
    /// last checkpoint (give no scene; --threads, --quiet and
    /// --checkpoint-every may be given).
    #[arg(long, value_name = "DIR")]
    resume: Option<PathBuf>,
}

fn run_command(scene_path: Option<&Path>, args: RunArgs) -> ExitCode {
    use crate::workflow::run::{CheckpointSettings, Progress, RunOptions, run_scene};
    if args.checkpoint_every == Some(0) {
        eprintln!("error: --checkpoint-every: must be at least 1");
        return ExitCode::from(2);
    }
    if let Some(dir) = &args.resume {
        return resume_command(scene_path, dir, &args);
    }
    if let Some(p) = scene_path
        && std::fs::read_to_string(p).is_ok_and(|t| crate::workflow::protocol::is_protocol(&t))
    {
        return protocol_command(p, args);
    }
    if let Some(p) = scene_path
        && std::fs::read_to_string(p)
            .is_ok_and(|t| crate::workflow::shape_diagram::is_shape_diagram(&t))
    {
        for (given, flag) in [
            (args.seed.is_some(), "--seed"),
            (args.frames.is_some(), "--frames"),
            (args.from.is_some(), "--from"),
            (args.checkpoint_every.is_some(), "--checkpoint-every"),
            (args.check_invariants, "--check-invariants"),
        ] {
            if given {
                eprintln!("error: {flag}: not available for a shape diagram");
                return ExitCode::from(2);
            }
        }
        let options = crate::workflow::shape_diagram::DiagramOptions {
            overwrite: args.overwrite,
            meshes: None,
            iterations: args.iterations,
            progress: !args.quiet,
        };
        return diagram_command(p, args.out, options, args.threads);
    }
    let path = scene_path.map_or_else(|| PathBuf::from(BUNDLED_SCENE_NAME), Path::to_path_buf);
    let text = match scene_path {
        Some(p) => std::fs::read_to_string(p).map_err(|source| crate::scene::SceneError::Read {
            path: p.to_path_buf(),
            source,
        }),
        None => Ok(BUNDLED_SCENE.to_string()),
    };
    let scene = match text.and_then(|t| Scene::from_ron_str(&t, &path).map(|s| (s, t))) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let (scene, text) = scene;
    if let Err(code) = set_threads(args.threads) {
        return code;
    }
    // Checkpoints keep the text the scene was parsed from.
    let checkpoint = args.checkpoint_every.map(|every| CheckpointSettings {
        every,
        scene_text: text,
    });
    let name = crate::workflow::run::run_name(&scene, &path);
    let out = args
        .out
        .unwrap_or_else(|| free_directory(Path::new("out").join(&name)));
    let progress = Progress::for_stderr(args.quiet);
    let options = RunOptions {
        out,
        overwrite: args.overwrite,
        seed: args.seed,
        iterations: args.iterations,
        frames: args.frames,
        from: args.from,
        progress,
        check_invariants: args.check_invariants,
        checkpoint,
    };
    let result = crate::util::parallel::on_pool(|| run_scene(&scene, &path, &options, |_| Ok(())));
    report_run(&path, &options.out, args.quiet, result)
}

/// Sets the global thread pool's size (`--threads`); a bad value is
/// reported with exit code 2.
fn set_threads(threads: Option<usize>) -> Result<(), ExitCode> {
    if let Some(n) = threads
        && let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
    {
        eprintln!("error: --threads {n}: {e}");
        return Err(ExitCode::from(2));
    }
    Ok(())
}

/// `remembrane run --resume DIR`: continues a run from its checkpoint.
fn resume_command(scene_path: Option<&Path>, dir: &Path, args: &RunArgs) -> ExitCode {
    let fixed = [
        (scene_path.is_some(), "a scene"),
        (args.out.is_some(), "--out"),
        (args.overwrite, "--overwrite"),
        (args.seed.is_some(), "--seed"),
        (args.iterations.is_some(), "--iterations"),
        (args.frames.is_some(), "--frames"),
        (args.from.is_some(), "--from"),
        (args.check_invariants, "--check-invariants"),
    ];
    if let Some((_, what)) = fixed.iter().find(|(given, _)| *given) {
        eprintln!(
            "error: --resume {}: {what} cannot be given; a resumed run keeps the scene and options it was started with",
            dir.display()
        );
        return ExitCode::from(2);
    }
    match crate::workflow::protocol::ProtocolRun::read(dir) {
        Some(Ok(record)) => return resume_protocol_command(dir, record, args),
        Some(Err(e)) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
        None => {}
    }
    if let Err(code) = set_threads(args.threads) {
        return code;
    }
    let progress = crate::workflow::run::Progress::for_stderr(args.quiet);
    let result = crate::util::parallel::on_pool(|| {
        crate::workflow::run::resume_run(dir, progress, args.checkpoint_every)
    });
    let out = crate::io::checkpoint::run_dir_of(dir);
    report_run(dir, &out, args.quiet, result)
}

/// Prints a run's outcome (its summary line and timing table, or its
/// error) and gives the exit code.
fn report_run(
    path: &Path,
    out: &Path,
    quiet: bool,
    result: Result<crate::workflow::run::RunSummary, crate::workflow::run::RunError>,
) -> ExitCode {
    match result {
        Ok(summary) => {
            for caution in &summary.cautions {
                eprintln!("warning: {}: {caution}", path.display());
            }
            if !quiet {
                eprintln!(
                    "{}: {} iterations, t = {:.4} s, {:.1} s wall; E = {:.6} Ē, A = {:.3}, V = {:.3}, v = {:.4}",
                    summary.last.scene,
                    summary.iterations,
                    summary.simulated_time,
                    summary.wall_time_s,
                    summary.last.total_energy,
                    summary.last.area,
                    summary.last.volume,
                    summary.last.reduced_volume
                );
                if let Some(m) = &summary.minimiser {
                    eprintln!(
                        "minimiser: stopped by {} (largest force {:.3e} Ē/l̄, constraint violation {:.1e}, {} restarts)",
                        m.stopped_by, m.force_residual, m.constraint_violation, m.restarts
                    );
                }
                if let Some(c) = &summary.constraints {
                    eprintln!(
                        "constraints: tension σ = {:.6e} Ē/l̄², pressure Δp = {:.6e} Ē/l̄³",
                        c.reactions.tension, c.reactions.pressure
                    );
                }
                if let Some(line) = model_line(&summary.model) {
                    eprintln!("{line}");
                }
                if let Some(caution) = &summary.model.caution {
                    eprintln!("note: {caution}");
                }
                eprintln!("outputs in {}", out.display());
                let table = crate::engine::schedule::format_timings(&summary.timings);
                eprint!("{table}");
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {}: {e}", path.display());
            ExitCode::from(e.exit_code())
        }
    }
}

/// One line on the membrane model: V_in's shear modulus and γ, and in the
/// fluid model its residuals (`None` when there is nothing to say).
fn model_line(m: &crate::fluid::ModelSummary) -> Option<String> {
    let mut parts = Vec::new();
    if let Some(v) = m.vin_moduli {
        parts.push(format!("V_in shear modulus {:.3e} Ē/l̄²", v.shear));
    }
    if let Some(g) = m.foppl_von_karman {
        parts.push(format!("γ = Y·A/(4πκ) = {g:.3}"));
    }
    if let Some(r) = m.residuals {
        parts.push(format!(
            "normal residual {:.3e} Ē/l̄, net force {:.1e} Ē/l̄",
            r.normal_residual, r.net_force
        ));
    }
    (m.name == "fluid" || !parts.is_empty())
        .then(|| format!("model {}: {}", m.name, parts.join(", ")))
}

/// `remembrane run PROTOCOL`: every phase in order into one directory.
fn protocol_command(path: &Path, args: RunArgs) -> ExitCode {
    use crate::workflow::protocol::{PhaseRunOptions, Protocol, run_protocol};
    use crate::workflow::run::Progress;
    let fail = |message: String, code: u8| {
        eprintln!("error: {message}");
        ExitCode::from(code)
    };
    for (given, flag) in [
        (args.seed.is_some(), "--seed"),
        (args.from.is_some(), "--from"),
    ] {
        if given {
            return fail(
                format!(
                    "{}: {flag} does not apply to a protocol (set `seed` or `start` per phase)",
                    path.display()
                ),
                2,
            );
        }
    }
    let loaded = match Protocol::load(path) {
        Ok(l) => l,
        Err(e) => return fail(e.to_string(), e.exit_code()),
    };
    if let Err(code) = set_threads(args.threads) {
        return code;
    }
    let out = args
        .out
        .unwrap_or_else(|| free_directory(Path::new("out").join(&loaded.protocol.name)));
    let progress = Progress::for_stderr(args.quiet);
    let options = PhaseRunOptions {
        progress,
        iterations: args.iterations,
        frames: args.frames,
        check_invariants: args.check_invariants,
        skip_completed: false,
        checkpoint_every: args.checkpoint_every,
        resume: false,
    };
    let result =
        crate::util::parallel::on_pool(|| run_protocol(&loaded, &out, args.overwrite, &options));
    report_protocol(path, &out, args.quiet, result)
}

/// `remembrane run --resume DIR` of a protocol run started with
/// `--checkpoint-every`: continues it from its record.
fn resume_protocol_command(
    dir: &Path,
    record: crate::workflow::protocol::ProtocolRun,
    args: &RunArgs,
) -> ExitCode {
    use crate::workflow::protocol::{PhaseRunOptions, Protocol, run_protocol};
    let loaded = match Protocol::load(&record.protocol) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(e.exit_code());
        }
    };
    if let Err(code) = set_threads(args.threads) {
        return code;
    }
    let options = PhaseRunOptions {
        progress: crate::workflow::run::Progress::for_stderr(args.quiet),
        iterations: record.iterations,
        frames: record.frames,
        check_invariants: record.check_invariants,
        skip_completed: false,
        checkpoint_every: Some(args.checkpoint_every.unwrap_or(record.checkpoint_every)),
        resume: true,
    };
    let out = crate::io::checkpoint::run_dir_of(dir);
    let result = crate::util::parallel::on_pool(|| run_protocol(&loaded, &out, false, &options));
    report_protocol(&record.protocol, &out, args.quiet, result)
}

/// Prints a protocol's outcome (a line per phase, or its error) and gives
/// the exit code.
fn report_protocol(
    path: &Path,
    out: &Path,
    quiet: bool,
    result: Result<
        crate::workflow::protocol::ProtocolSummary,
        crate::workflow::protocol::ProtocolError,
    >,
) -> ExitCode {
    match result {
        Ok(summary) => {
            if !quiet {
                for p in &summary.phases {
                    eprintln!(
                        "{}: {} iterations, t = {:.4} s, {:.1} s wall",
                        p.name, p.iterations, p.simulated_time, p.wall_time_s
                    );
                }
                eprintln!("outputs in {}", out.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {}: {e}", path.display());
            ExitCode::from(e.exit_code())
        }
    }
}

fn compare_command(
    first: &Path,
    second: &Path,
    iterations: Option<u64>,
    out: Option<PathBuf>,
    overwrite: bool,
    seed: Option<u64>,
    quiet: bool,
) -> ExitCode {
    use crate::workflow::compare::{ComparisonRow, chart_png, csv, table};
    use crate::workflow::run::{Progress, RunOptions, run_scene};
    let mut scenes = Vec::new();
    for path in [first, second] {
        match Scene::load(path) {
            Ok(s) => scenes.push((s, path.to_path_buf())),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(2);
            }
        }
    }
    let names: Vec<String> = scenes
        .iter()
        .map(|(s, p)| crate::workflow::run::run_name(s, p))
        .collect();
    if names[0] == names[1] {
        eprintln!(
            "error: both scenes are named `{}`; give them different `name`s",
            names[0]
        );
        return ExitCode::from(2);
    }
    let dir = out.unwrap_or_else(|| {
        free_directory(Path::new("out").join(format!("compare-{}-{}", names[0], names[1])))
    });
    if dir.exists() {
        if !overwrite {
            eprintln!(
                "error: {}: output directory already exists (choose another --out or pass --overwrite)",
                dir.display()
            );
            return ExitCode::from(2);
        }
        if let Err(e) = std::fs::remove_dir_all(&dir) {
            eprintln!("error: {}: cannot replace: {e}", dir.display());
            return ExitCode::from(1);
        }
    }
    let mut rows = Vec::new();
    for ((scene, path), name) in scenes.iter().zip(&names) {
        let options = RunOptions {
            out: dir.join(name),
            overwrite: false,
            seed,
            iterations,
            frames: None,
            from: None,
            progress: if quiet {
                Progress::Quiet
            } else {
                Progress::Lines
            },
            check_invariants: false,
            checkpoint: None,
        };
        match run_scene(scene, path, &options, |_| Ok(())) {
            Ok(summary) => rows.push(ComparisonRow::from_summary(&summary)),
            Err(e) => {
                eprintln!("error: {}: {e}", path.display());
                return ExitCode::from(e.exit_code());
            }
        }
    }
    let rows: [ComparisonRow; 2] = [rows[0].clone(), rows[1].clone()];
    let written = crate::atomic_write(&dir.join("comparison.csv"), csv(&rows).as_bytes())
        .and_then(|_| crate::atomic_write(&dir.join("comparison.png"), &chart_png(&rows)));
    if let Err(e) = written {
        eprintln!("error: {}: cannot write the comparison: {e}", dir.display());
        return ExitCode::from(1);
    }
    say_raw!("{}", table(&rows));
    if !quiet {
        eprintln!("comparison in {}", dir.display());
    }
    ExitCode::SUCCESS
}

/// `base`, or `base.1`, `base.2`, … whichever does not exist yet, so a new
/// run never mixes with an earlier one.
fn free_directory(base: PathBuf) -> PathBuf {
    if !base.exists() {
        return base;
    }
    (1..)
        .map(|k| {
            let mut p = base.clone().into_os_string();
            p.push(format!(".{k}"));
            PathBuf::from(p)
        })
        .find(|p| !p.exists())
        .unwrap_or(base)
}

fn run(command: Command) -> Result<(), String> {
    match command {
        Command::Run { .. }
        | Command::Compare { .. }
        | Command::Sweep { .. }
        | Command::Collect { .. }
        | Command::Study { .. }
        | Command::Diagram { .. } => unreachable!("handled in main"),
        Command::Check { scene } => check(&scene),
        Command::Spectrum {
            dir,
            equilibration,
            l_min,
            l_max,
            blocks,
            kbt,
            kappa,
            discrete,
        } => spectrum_command(
            &dir,
            equilibration,
            (l_min, l_max),
            blocks,
            kbt,
            kappa,
            discrete,
        ),
        Command::Energy {
            scene,
            json,
            forces,
        } => energy(&scene, json, forces.as_deref()),
    }
}

/// `remembrane check PROTOCOL`: every phase's scene and start.
fn check_protocol(path: &Path) -> Result<(), String> {
    let loaded = crate::workflow::protocol::Protocol::load(path).map_err(|e| e.to_string())?;
    say!(
        "{}: ok (protocol `{}`)",
        path.display(),
        loaded.protocol.name
    );
    for (phase, (scene, scene_path)) in loaded.protocol.phases.iter().zip(&loaded.scenes) {
        say!(
            "  phase {:<12} {} ({} iterations{}), start {:?}",
            phase.name,
            scene_path.display(),
            scene.dynamics.iterations,
            scene
                .dynamics
                .duration
                .map(|t| format!(", at most {t} s"))
                .unwrap_or_default(),
            phase.start
        );
    }
    Ok(())
}

fn load(path: &Path) -> Result<(Scene, crate::engine::simulation::Simulation), String> {
    let scene = Scene::load(path).map_err(|e| e.to_string())?;
    let sim = scene.build(path).map_err(|e| e.to_string())?;
    Ok((scene, sim))
}

/// The scene a run directory's summary names, if it still loads.
fn run_scene_file(dir: &Path) -> Option<Scene> {
    let summary = crate::workflow::run::RunSummary::read(dir).ok()?;
    Scene::load(Path::new(&summary.scene_file)).ok()
}

fn spectrum_command(
    dir: &Path,
    equilibration: f64,
    (l_min, l_max): (usize, usize),
    blocks: usize,
    kbt: Option<f64>,
    kappa: Option<f64>,
    discrete: bool,
) -> Result<(), String> {
    if !dir.join("summary.json").is_file() {
        return Err(format!(
            "{}: no summary.json: not a run directory",
            dir.display()
        ));
    }
    let scene = run_scene_file(dir);
    let kbt = kbt
        .or_else(|| scene.as_ref().map(|s| s.dynamics.temperature))
        .ok_or_else(|| {
            format!(
                "{}: the run's scene cannot be read: give --kbt",
                dir.display()
            )
        })?;
    if !(kbt > 0.0 && kbt.is_finite()) {
        return Err(format!(
            "k_BT must be > 0 (got {kbt}): is this a run with noise?"
        ));
    }
    let kappa_input = kappa.or_else(|| {
        scene.as_ref()?.energy.iter().find_map(|t| match t {
            crate::scene::EnergyTerm::Bending(p) => Some(p.kappa),
            _ => None,
        })
    });
    let options = crate::analysis::spectrum::SpectrumOptions {
        equilibration,
        l_min,
        l_max,
        blocks,
        kbt,
        kappa_input,
        discrete,
    };
    let s = crate::analysis::spectrum::analyse_run(dir, &options)?;
    say!(
        "{} frames, R0 = {:.4} l̄, l = {}..={}: κ = {:.4} ± {:.4} Ē, σ = {:.4e} ± {:.1e} Ē/l̄², χ²/dof = {:.2}",
        s.frames,
        s.mean_radius,
        s.l_min,
        s.l_max,
        s.kappa,
        s.kappa_error,
        s.sigma,
        s.sigma_error,
        s.chi2_per_dof
    );
    if let Some(k) = kappa_input {
        say!("input κ = {k} Ē: fitted/input = {:.3}", s.kappa / k);
    }
    Ok(())
}

fn check(path: &Path) -> Result<(), String> {
    if std::fs::read_to_string(path).is_ok_and(|t| crate::workflow::protocol::is_protocol(&t)) {
        return check_protocol(path);
    }
    let (scene, mut sim) = load(path)?;
    let initial = *sim.resource::<crate::engine::simulation::InitialState>();
    let mesh_mean_edge = sim
        .membrane_mut()
        .to_mesh()
        .map_err(|e| e.to_string())?
        .mean_edge_length();
    let t = sim.membrane_mut().topology().map_err(|e| e.to_string())?;
    say!("{}: ok", path.display());
    for caution in scene.cautions() {
        say!("  warning: {caution}");
    }
    say!(
        "  name         {}",
        crate::workflow::run::run_name(&scene, path)
    );
    say!("  seed         {}", scene.seed);
    say!("  membrane     {:?}", scene.membrane);
    say!(
        "  mesh         {} vertices, {} edges, {} faces",
        t.vertex_count(),
        t.edges.len(),
        t.faces.len()
    );
    say!(
        "  valence      {}..={}",
        scene.valence.min,
        scene.valence.max
    );
    say!(
        "  lipid        {}",
        if scene.lipid_density {
            "per-vertex density"
        } else {
            "none"
        }
    );
    say!(
        "  initial      area {:.4} l̄², volume {:.4} l̄³",
        initial.area,
        initial.volume
    );
    say!("  energy terms {}", scene.energy.len());
    for term in &scene.energy {
        say!("    {term:?}");
    }
    say!("  systems      {}", scene.systems.len());
    for system in &scene.systems {
        say!("    {system:?}");
    }
    say!("  penalty smoothing passes {}", scene.penalty_smoothing);
    say!(
        "  model        {}",
        match scene.model {
            crate::params::MembraneModel::Paper =>
                "Paper (V_in acts on the shape: an elastic shell)",
            crate::params::MembraneModel::Fluid(_) =>
                "Fluid (V_in acts in the tangent planes only: no shear modulus)",
        }
    );
    let h = scene.resolution.edge_length(mesh_mean_edge);
    if h != 1.0 {
        let r = scene.at_resolution(h);
        let well = r
            .energy
            .iter()
            .find_map(|t| match t {
                crate::scene::EnergyTerm::Vin(p) => Some((p.near_barrier.1, p.far_barrier.0)),
                _ => None,
            })
            .unwrap_or((f64::NAN, f64::NAN));
        say!(
            "  resolution   h = {h:.5} l̄: V_in well ({:.4}, {:.4}), triggers ({:.4}, {:.4}), \
             mobility per vertex {:.6e} l̄²/(Ē s)",
            well.0,
            well.1,
            r.remesh.shorter_than,
            r.remesh.longer_than,
            r.dynamics.mobility
        );
    }
    if let Some(c) = &scene.constraints {
        let (area, volume) = c.targets(initial.area, initial.volume);
        let show = |x: Option<f64>| x.map_or("free".to_string(), |x| format!("{x:.4}"));
        let reduced = match (area, volume) {
            (Some(a), Some(v)) => format!(
                " (reduced volume {:.4})",
                crate::mesh::geometry::reduced_volume(v, a)
            ),
            _ => String::new(),
        };
        say!(
            "  constraints  area {} l̄², volume {} l̄³{reduced}, held exactly",
            show(area),
            show(volume)
        );
    }
    match scene.dynamics.method {
        crate::params::Method::Overdamped => say!(
            "  dynamics     overdamped, {} iterations",
            scene.dynamics.iterations
        ),
        crate::params::Method::Minimise(m) => say!(
            "  dynamics     FIRE minimiser, at most {} iterations, until the largest force < {:e} Ē/l̄ or |ΔE|/E < {:e} over {}",
            scene.dynamics.iterations,
            m.force_tolerance,
            m.energy_tolerance,
            m.energy_window
        ),
    }
    say!("  control points {}", scene.control_points.len());
    Ok(())
}

fn energy(path: &Path, json: bool, forces: Option<&Path>) -> Result<(), String> {
    let (scene, mut sim) = load(path)?;
    sim.evaluate_forces().map_err(|e| e.to_string())?;
    let report = EnergyReport::new(&crate::workflow::run::run_name(&scene, path), &sim);
    if let Some(bad) = report.energies.iter().find(|e| !e.energy.is_finite()) {
        return Err(format!(
            "{}: energy term `{}` is not finite ({})",
            path.display(),
            bad.term,
            bad.energy
        ));
    }
    if let Some(out) = forces {
        crate::atomic_write(out, forces_csv(&sim).as_bytes())
            .map_err(|e| format!("{}: cannot write forces: {e}", out.display()))?;
    }
    if json {
        say!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?
        );
    } else {
        say_raw!("{}", report.to_text());
    }
    Ok(())
}

/// The options of `remembrane sweep`.
struct SweepArgs {
    out: Option<PathBuf>,
    jobs: Option<usize>,
    shard: Option<String>,
    iterations: Option<u64>,
    emit_slurm: bool,
    tasks: Option<usize>,
    phases_only: bool,
    quiet: bool,
}

/// `remembrane study`: runs the cases not yet finished, then measures and
/// reports all of them. Exit 2 for a bad study file, 1 if a case failed to
/// run (a run that blew up is a result, not a failure) or the report could
/// not be written.
fn study_command(
    path: &Path,
    out: Option<PathBuf>,
    jobs: usize,
    quick: bool,
    no_peers: bool,
    quiet: bool,
) -> ExitCode {
    use crate::study::{Study, StudyOptions, run_cases, selected};
    let (study, cases) = match Study::load(path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let cases = selected(&study, cases, quick);
    let options = StudyOptions {
        out: out.unwrap_or_else(|| PathBuf::from("out").join(&study.name)),
        jobs,
        quiet,
    };
    let ran = match run_cases(&study, &cases, &options) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    if !quiet {
        eprintln!(
            "study {}: {} cases, {} run now, {} already done, {} failed",
            study.name,
            ran.cases,
            ran.completed,
            ran.skipped,
            ran.failed.len()
        );
    }
    for (dir, e) in &ran.failed {
        eprintln!("error: {}: {e}", options.out.join(dir).display());
    }
    let peers = if no_peers {
        Vec::new()
    } else {
        crate::study::peer::run_peers(&study, path, &cases, &options.out, quiet)
    };
    let report = crate::study::report::evaluate(&study, &cases, &peers, &options.out);
    if let Err(e) = crate::study::report::write_report(&report, &options.out) {
        eprintln!("error: {e}");
        return ExitCode::from(1);
    }
    say_raw!("{}", crate::study::report::markdown(&report));
    if ran.failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// `remembrane diagram FILE` (and `remembrane run FILE` on a shape
/// diagram): exit 2 for a bad file, 1 if a point did not complete (the
/// outputs then stay in OUT.incomplete).
fn diagram_command(
    path: &Path,
    out: Option<PathBuf>,
    options: crate::workflow::shape_diagram::DiagramOptions,
    threads: Option<usize>,
) -> ExitCode {
    use crate::workflow::shape_diagram::{ShapeDiagram, markdown, run_diagram};
    let loaded = match ShapeDiagram::load(path) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(e.exit_code());
        }
    };
    if let Err(code) = set_threads(threads) {
        return code;
    }
    let out = out.unwrap_or_else(|| PathBuf::from("out").join(&loaded.diagram.name));
    let quiet = !options.progress;
    match run_diagram(&loaded, &out, &options) {
        Ok(summary) => {
            if !quiet {
                say_raw!("{}", markdown(&summary));
                eprintln!("wrote {}", out.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

fn sweep_command(sweep_path: &Path, args: SweepArgs) -> ExitCode {
    use crate::workflow::slurm::{slurm_campaign_script, slurm_script};
    use crate::workflow::sweep::{Sweep, SweepError, SweepOptions, parse_shard, run_sweep};
    let SweepArgs {
        out,
        jobs,
        shard,
        iterations,
        emit_slurm,
        tasks,
        phases_only,
        quiet,
    } = args;
    let fail = |message: String| {
        eprintln!("error: {message}");
        ExitCode::from(2)
    };
    let (sweep, _) = match Sweep::load(sweep_path) {
        Ok(s) => s,
        Err(e) => return fail(e.to_string()),
    };
    let out = out.unwrap_or_else(|| PathBuf::from("out").join(&sweep.name));
    if emit_slurm {
        let runs = sweep.expand().len();
        let tasks = tasks.unwrap_or(runs).clamp(1, runs.max(1));
        // Slurm opens the tasks' log files in the output directory before
        // the script runs: it must exist at submission.
        if let Err(e) = std::fs::create_dir_all(&out) {
            return fail(format!("{}: cannot create: {e}", out.display()));
        }
        let binary = std::env::current_exe().unwrap_or_else(|_| PathBuf::from("remembrane"));
        let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_owned());
        let emit = if sweep.phases.is_empty() {
            slurm_script
        } else {
            slurm_campaign_script
        };
        say_raw!(
            "{}",
            emit(&sweep.name, &binary, &abs(sweep_path), &abs(&out), tasks)
        );
        return ExitCode::SUCCESS;
    }
    let shard = match shard.as_deref().map(parse_shard).transpose() {
        Ok(s) => s,
        Err(e) => return fail(e),
    };
    let options = SweepOptions {
        out: out.clone(),
        jobs: jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())),
        shard,
        iterations,
        quiet,
        phases_only,
    };
    match run_sweep(sweep_path, &options) {
        Ok(report) if phases_only => {
            eprintln!(
                "sweep {}: {} shared phases ready in {}",
                sweep.name,
                report.phases.len(),
                crate::workflow::sweep::phases_dir(&out).display()
            );
            ExitCode::SUCCESS
        }
        Ok(report) => {
            eprintln!(
                "sweep {}: {} runs in all, {} in this shard: {} done now, {} already done, {} failed; results in {}",
                sweep.name,
                report.total,
                report.in_shard,
                report.completed,
                report.skipped,
                report.failed.len(),
                out.display()
            );
            for (dir, e) in &report.failed {
                eprintln!("  failed: {}: {e}", dir.display());
            }
            if report.failed.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
        Err(e @ SweepError::Phase { .. }) => {
            eprintln!("error: {}: {e}", sweep_path.display());
            ExitCode::from(1)
        }
        Err(e) => fail(e.to_string()),
    }
}

fn collect_command(dir: &Path, x: String, y: String, frames: usize, partial: bool) -> ExitCode {
    use crate::workflow::collect::{CollectOptions, collect};
    let options = CollectOptions {
        x,
        y,
        frames,
        ..Default::default()
    };
    match collect(dir, &options) {
        Ok(report) => {
            say!(
                "{} of {} runs collected{}",
                report.runs.len(),
                report.expected,
                if report.missing.is_empty() {
                    String::new()
                } else {
                    format!(", {} missing", report.missing.len())
                }
            );
            say!("condition,point,runs,mean,sd");
            for g in &report.groups {
                let point: Vec<String> = g.point.iter().map(|(a, v)| format!("{a}={v}")).collect();
                say!(
                    "{},{},{},{:.4},{:.4}",
                    g.condition,
                    point.join(" "),
                    g.n,
                    g.mean,
                    g.sd
                );
            }
            for m in &report.missing {
                eprintln!("  missing: {}", m.display());
            }
            if report.missing.is_empty() || partial {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
