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
    Run(RunCommandArgs),
    /// Run two remeshing scenes (e.g. free-energy vs geometric) and compare
    /// their remesh events and σ(|r|) (paper Fig 3C/D): a table, CSV and PNG.
    Compare(CompareArgs),
    /// Run a parameter sweep (base scene × conditions × grid × repeats),
    /// resumable, in parallel, or one shard of it; or print a Slurm
    /// job-array script that runs it.
    Sweep(SweepArgs),
    /// Aggregate a sweep's runs: 4th-order fit of one series.csv column
    /// against another per run, mean ± sd per condition and grid point
    /// (paper Fig 5E/F) as CSV tables and PNG charts in DIR.
    Collect(CollectArgs),
    /// The vesicle shape diagram: walk each branch of a ShapeDiagram file
    /// down its reduced volumes with the minimiser, each point from the one
    /// before, on each mesh; write diagram.csv, diagram.md, diagram.json and
    /// diagram.png (E_b/8πκ against v beside the axisymmetric solver's
    /// curves) in OUT and print the table. `remembrane run FILE` does the
    /// same with the defaults.
    Diagram(DiagramArgs),
    /// Speed against error: run a study's ladder of settings on reference
    /// problems with independent answers (resumable), then write study.csv,
    /// study.md, study.json and error-vs-cost / convergence charts in OUT
    /// and print the tables.
    Study(StudyArgs),
    /// Flicker spectrum of a fluctuating quasi-spherical vesicle run: its
    /// frames' shapes in spherical harmonics, ⟨|u_lm|²⟩ by l after an
    /// equilibration time, and the Helfrich fit of κ and σ with block
    /// error bars (spectrum.csv, spectrum_fit.json, spectrum.png in DIR).
    Spectrum(SpectrumArgs),
    /// Validate a scene and print what it declares.
    Check(CheckArgs),
    /// Evaluate the scene's initial state: energies per term, area, volume,
    /// reduced volume and mesh quality.
    Energy(EnergyArgs),
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
        Command::Run(a) => run_command(a.scene.as_deref(), a.args),
        Command::Compare(a) => compare_command(a),
        Command::Sweep(a) => sweep_command(a),
        Command::Collect(a) => collect_command(a),
        Command::Study(a) => study_command(a),
        Command::Diagram(a) => diagram_command(a),
        Command::Spectrum(a) => exit_code(spectrum_command(a)),
        Command::Check(a) => exit_code(check(&a.scene)),
        Command::Energy(a) => exit_code(energy(a)),
    }
}

/// Success, or the message on stderr and exit 2 (the commands that only
/// read: their one failure is bad input).
fn exit_code(result: Result<(), String>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
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
