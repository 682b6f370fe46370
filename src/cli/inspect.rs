//! `remembrane check`, `energy` and `spectrum`: reading a scene, a
//! protocol or a run without running it.

use super::*;

/// `remembrane check PROTOCOL`: every phase's scene and start.
pub(super) fn check_protocol(path: &Path) -> Result<(), String> {
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

/// The arguments of `remembrane spectrum`.
#[derive(clap::Args)]
pub(super) struct SpectrumArgs {
    /// Run directory (with summary.json and frames/).
    pub(super) dir: PathBuf,
    /// Frames before this simulated time are discarded (s).
    #[arg(long, default_value_t = 0.0)]
    pub(super) equilibration: f64,
    /// Lowest l fitted.
    #[arg(long, default_value_t = 2)]
    pub(super) l_min: usize,
    /// Highest l fitted.
    #[arg(long, default_value_t = 12)]
    pub(super) l_max: usize,
    /// Blocks of consecutive frames for the error bars.
    #[arg(long, default_value_t = 10)]
    pub(super) blocks: usize,
    /// k_BT (Ē; default: the run's scene's temperature).
    #[arg(long)]
    pub(super) kbt: Option<f64>,
    /// Input κ to draw (Ē; default: the run's scene's Bending kappa).
    #[arg(long)]
    pub(super) kappa: Option<f64>,
    /// Fit against the discrete bending energy's own stiffness against
    /// each mode (measured on the last frame's mesh) instead of the
    /// continuum's: the cotangent energy is softer for modes a few edges
    /// long, which a continuum fit reads as a lower κ.
    #[arg(long)]
    pub(super) discrete: bool,
}

pub(super) fn spectrum_command(args: SpectrumArgs) -> Result<(), String> {
    let SpectrumArgs {
        dir,
        equilibration,
        l_min,
        l_max,
        blocks,
        kbt,
        kappa,
        discrete,
    } = args;
    let dir = dir.as_path();
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
    let options = crate::io::spectrum::SpectrumOptions {
        equilibration,
        l_min,
        l_max,
        blocks,
        kbt,
        kappa_input,
        discrete,
    };
    let s = crate::io::spectrum::analyse_run(dir, &options).map_err(|e| e.to_string())?;
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

/// The arguments of `remembrane check`.
#[derive(clap::Args)]
pub(super) struct CheckArgs {
    /// Scene file (RON).
    pub(super) scene: PathBuf,
}

pub(super) fn check(path: &Path) -> Result<(), String> {
    if std::fs::read_to_string(path).is_ok_and(|t| crate::workflow::protocol::is_protocol(&t))
        || crate::scene::Scene::load(path).is_ok_and(|s| {
            matches!(
                s.resolution,
                crate::scene::resolution::Resolution::Ladder { .. }
            )
        })
    {
        // A refinement ladder is checked as the protocol of its rungs.
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
    let loops = t.boundary_loops().len();
    say!(
        "  mesh         {} vertices, {} edges, {} faces{}",
        t.vertex_count(),
        t.edges.len(),
        t.faces.len(),
        match loops {
            0 => String::new(),
            n => format!(", open: {n} boundary loop{}", if n == 1 { "" } else { "s" }),
        }
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
    say_resolution(&scene, mesh_mean_edge);
    say_constraints_and_dynamics(&scene, &initial);
    say!("  control points {}", scene.control_points.len());
    say_species(&scene);
    Ok(())
}

/// The species lines of `check`: each species' parameters, where its
/// proteins come from, and how its field moves in this scene's dynamics.
fn say_species(scene: &crate::scene::Scene) {
    let Some(set) = &scene.species else {
        return;
    };
    let minimiser = matches!(scene.dynamics.method, crate::params::Method::Minimise(_));
    say!(
        "  species      {} at k_BT {} Ē",
        set.species.len(),
        set.temperature
    );
    for s in &set.species {
        use crate::species::params::Reservoir;
        let source = match (s.reservoir, s.chemical_potential) {
            (Reservoir::Bulk, Some(mu)) => format!("bound from a bulk at μ {mu} Ē"),
            _ => "conserved".to_string(),
        };
        let moves = if minimiser {
            "relaxed with the minimiser".to_string()
        } else {
            let mut how = Vec::new();
            if s.mobility > 0.0 {
                let d = s.mobility * set.temperature / s.area_per_protein;
                how.push(format!("transport D = {d} l̄²/s"));
            }
            if s.reservoir == Reservoir::Bulk && s.binding_rate > 0.0 {
                how.push(format!("binding at {} /s", s.binding_rate));
            }
            match how.is_empty() {
                true => "held on the surface (no mobility or binding rate)".to_string(),
                false => how.join(", "),
            }
        };
        say!(
            "    {}: a_p {} l̄², c {} /l̄, Δκ {} Ē, ε {} Ē/l̄², η {} Ē; {source}; {moves}",
            s.name,
            s.area_per_protein,
            s.curvature_coupling,
            s.rigidity_change,
            s.binding_energy,
            s.gradient_energy
        );
    }
}

/// The resolution line of `check`: the rescaled V_in well, triggers and
/// mobility, when the scene asks for a resolution other than 1.
fn say_resolution(scene: &crate::scene::Scene, mesh_mean_edge: f64) {
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
}

/// The constraints and dynamics lines of `check`.
fn say_constraints_and_dynamics(
    scene: &crate::scene::Scene,
    initial: &crate::engine::simulation::InitialState,
) {
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
}

/// The arguments of `remembrane energy`.
#[derive(clap::Args)]
pub(super) struct EnergyArgs {
    /// Scene file (RON).
    pub(super) scene: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub(super) json: bool,
    /// Also write per-vertex forces (each term and the total) as CSV.
    #[arg(long, value_name = "FILE.csv")]
    pub(super) forces: Option<PathBuf>,
}

pub(super) fn energy(args: EnergyArgs) -> Result<(), String> {
    let EnergyArgs {
        scene: path,
        json,
        forces,
    } = args;
    let (path, forces) = (path.as_path(), forces.as_deref());
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
