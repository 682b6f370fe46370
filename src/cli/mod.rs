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
mod campaign;
mod compare;
mod inspect;
mod run;

use campaign::*;
use compare::*;
use inspect::*;
use run::*;

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
const BUNDLED_SCENE: &str = include_str!("../../scenes/red_blood_cell.ron");
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

fn load(path: &Path) -> Result<(Scene, crate::engine::simulation::Simulation), String> {
    let scene = Scene::load(path).map_err(|e| e.to_string())?;
    let sim = scene.build(path).map_err(|e| e.to_string())?;
    Ok((scene, sim))
}

/// The scene a run directory's summary names, if it still loads.
fn run_scene_file(dir: &Path) -> Option<Scene> {
    let summary = crate::io::summary::RunSummary::read(dir).ok()?;
    Scene::load(Path::new(&summary.scene_file)).ok()
}
