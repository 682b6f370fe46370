//! The `remembrane` command line.

use clap::{Parser, Subcommand};
use remembrane::report::{EnergyReport, forces_csv};
use remembrane::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Membrane simulation with free-energy-controlled remeshing.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}

fn run(command: Command) -> Result<(), String> {
    match command {
        Command::Check { scene } => check(&scene),
        Command::Energy {
            scene,
            json,
            forces,
        } => energy(&scene, json, forces.as_deref()),
    }
}

fn load(path: &Path) -> Result<(Scene, remembrane::simulation::Simulation), String> {
    let scene = Scene::load(path).map_err(|e| e.to_string())?;
    let sim = scene.build(path).map_err(|e| e.to_string())?;
    Ok((scene, sim))
}

fn scene_name(scene: &Scene, path: &Path) -> String {
    if scene.name.is_empty() {
        path.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    } else {
        scene.name.clone()
    }
}

fn check(path: &Path) -> Result<(), String> {
    let (scene, mut sim) = load(path)?;
    let t = sim.state.membrane.topology().map_err(|e| e.to_string())?;
    println!("{}: ok", path.display());
    println!("  name         {}", scene_name(&scene, path));
    println!("  seed         {}", scene.seed);
    println!("  membrane     {:?}", scene.membrane);
    println!(
        "  mesh         {} vertices, {} edges, {} faces",
        t.vertex_count(),
        t.edges.len(),
        t.faces.len()
    );
    println!(
        "  valence      {}..={}",
        scene.valence.min, scene.valence.max
    );
    println!(
        "  lipid        {}",
        if scene.lipid_density {
            "per-vertex density"
        } else {
            "none"
        }
    );
    println!(
        "  initial      area {:.4} l̄², volume {:.4} l̄³",
        sim.state.initial.area, sim.state.initial.volume
    );
    println!("  energy terms {}", scene.energy.len());
    for term in &scene.energy {
        println!("    {term:?}");
    }
    println!("  penalty smoothing passes {}", scene.penalty_smoothing);
    println!("  control points {}", scene.control_points.len());
    Ok(())
}

fn energy(path: &Path, json: bool, forces: Option<&Path>) -> Result<(), String> {
    let (scene, mut sim) = load(path)?;
    sim.evaluate_forces().map_err(|e| e.to_string())?;
    let report = EnergyReport::new(&scene_name(&scene, path), &sim.state);
    if let Some(bad) = report.energies.iter().find(|e| !e.energy.is_finite()) {
        return Err(format!(
            "{}: energy term `{}` is not finite ({})",
            path.display(),
            bad.term,
            bad.energy
        ));
    }
    if let Some(out) = forces {
        remembrane::atomic_write(out, forces_csv(&sim.state).as_bytes())
            .map_err(|e| format!("{}: cannot write forces: {e}", out.display()))?;
    }
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?
        );
    } else {
        print!("{}", report.to_text());
    }
    Ok(())
}
