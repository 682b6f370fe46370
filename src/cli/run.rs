//! `remembrane run` and `remembrane resume` of a scene or a protocol, and
//! what they print.

use super::*;

/// The arguments of `remembrane run`.
#[derive(clap::Args)]
pub(super) struct RunCommandArgs {
    /// Scene file (RON); default: the bundled red_blood_cell.ron.
    pub(super) scene: Option<PathBuf>,
    #[command(flatten)]
    pub(super) args: RunArgs,
}

/// Options of `remembrane run`.
#[derive(clap::Args)]
pub(super) struct RunArgs {
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
    /// Check every mesh invariant after each remesh edit (debug mode; slow;
    /// always on in a debug build unless `--no-check-invariants`).
    #[arg(long, conflicts_with = "no_check_invariants")]
    check_invariants: bool,
    /// Skip the invariant checks a debug build runs after each remesh edit
    /// (for a debug build's runs that need only their outputs).
    #[arg(long)]
    no_check_invariants: bool,
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

impl RunArgs {
    /// `--check-invariants` or `--no-check-invariants`, if either was given
    /// (`None`: the build's default).
    fn invariant_checks(&self) -> Option<bool> {
        match (self.check_invariants, self.no_check_invariants) {
            (true, _) => Some(true),
            (_, true) => Some(false),
            _ => None,
        }
    }
}

pub(super) fn run_command(scene_path: Option<&Path>, args: RunArgs) -> ExitCode {
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
            (args.no_check_invariants, "--no-check-invariants"),
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
        return run_diagram_file(p, args.out, options, args.threads);
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
    if let (Some(p), crate::scene::resolution::Resolution::Ladder { .. }) =
        (scene_path, scene.resolution)
    {
        // The refinement ladder runs as the protocol of its rungs.
        return protocol_command(p, args);
    }
    if let Err(code) = set_threads(args.threads) {
        return code;
    }
    // Checkpoints keep the text the scene was parsed from.
    let checkpoint = args.checkpoint_every.map(|every| CheckpointSettings {
        every,
        scene_text: text,
    });
    let name = crate::workflow::run::run_name(&scene, &path);
    let check_invariants = args.invariant_checks();
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
        check_invariants,
        checkpoint,
    };
    // Before the run, which such a setting can make very slow.
    for caution in scene.cautions() {
        eprintln!("warning: {}: {caution}", path.display());
    }
    let result = crate::util::parallel::on_pool(|| run_scene(&scene, &path, &options, |_| Ok(())));
    report_run(&path, &options.out, args.quiet, result, Cautions::Shown)
}

/// Whether [`report_run`] still prints the summary's cautions.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Cautions {
    /// Printed before the run started.
    Shown,
    /// Printed with the outcome (a resumed run).
    WithOutcome,
}

/// Sets the global thread pool's size (`--threads`); a bad value is
/// reported with exit code 2.
pub(super) fn set_threads(threads: Option<usize>) -> Result<(), ExitCode> {
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
pub(super) fn resume_command(scene_path: Option<&Path>, dir: &Path, args: &RunArgs) -> ExitCode {
    let fixed = [
        (scene_path.is_some(), "a scene"),
        (args.out.is_some(), "--out"),
        (args.overwrite, "--overwrite"),
        (args.seed.is_some(), "--seed"),
        (args.iterations.is_some(), "--iterations"),
        (args.frames.is_some(), "--frames"),
        (args.from.is_some(), "--from"),
        (args.check_invariants, "--check-invariants"),
        (args.no_check_invariants, "--no-check-invariants"),
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
    report_run(dir, &out, args.quiet, result, Cautions::WithOutcome)
}

/// Prints a run's outcome (its summary line and timing table, or its
/// error; the summary's cautions unless they were shown before the run)
/// and gives the exit code.
pub(super) fn report_run(
    path: &Path,
    out: &Path,
    quiet: bool,
    result: Result<crate::io::summary::RunSummary, crate::workflow::run::RunError>,
    cautions: Cautions,
) -> ExitCode {
    match result {
        Ok(summary) => {
            if cautions == Cautions::WithOutcome {
                for caution in &summary.cautions {
                    eprintln!("warning: {}: {caution}", path.display());
                }
            }
            for note in &summary.time_notes {
                eprintln!("note: {}: {note}", path.display());
            }
            if !quiet {
                let volume = match (summary.last.volume, summary.last.reduced_volume) {
                    (Some(v), Some(rv)) => format!(", V = {v:.3}, v = {rv:.4}"),
                    _ => String::new(),
                };
                eprintln!(
                    "{}: {} iterations, t = {:.4} s, {:.1} s wall; E = {:.6} Ē, A = {:.3}{volume}",
                    summary.last.scene,
                    summary.iterations,
                    summary.simulated_time,
                    summary.wall_time_s,
                    summary.last.total_energy,
                    summary.last.area,
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
                if let Ok(Some(a)) = summary.section::<crate::analysis::adhesion::AdhesionReport>(
                    crate::analysis::adhesion::ADHESION_SECTION,
                ) {
                    let curvature = match (a.contact_curvature, a.contact_curvature_error) {
                        (Some(c), Some(e)) => format!(
                            "{c:.4} ± {e:.1e} /l̄ ({:+.1} %)",
                            100.0 * (c / a.contact_condition - 1.0)
                        ),
                        _ => "not measured".into(),
                    };
                    eprintln!(
                        "adhesion (W R0²/κ = {:.2}): contact curvature {curvature} against √(2W/κ) = {:.4} /l̄; height {:.3} l̄ against the continuum's {:.3}",
                        a.reduced_adhesion, a.contact_condition, a.height, a.continuum_height
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
        // A scene error names its file (and line) itself.
        Err(e @ crate::workflow::run::RunError::Scene(_)) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
        Err(e) => {
            eprintln!("error: {}: {e}", path.display());
            ExitCode::from(e.exit_code())
        }
    }
}

/// One line on the membrane model: V_in's shear modulus and γ, and in the
/// fluid model its residuals (`None` when there is nothing to say).
pub(super) fn model_line(m: &crate::fluid::ModelSummary) -> Option<String> {
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
pub(super) fn protocol_command(path: &Path, args: RunArgs) -> ExitCode {
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
                    "{}: {flag} does not apply to a protocol or a resolution ladder (set \
                     `seed` or `start` in the scenes)",
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
    let check_invariants = args.invariant_checks();
    let out = args
        .out
        .unwrap_or_else(|| free_directory(Path::new("out").join(&loaded.protocol.name)));
    let progress = Progress::for_stderr(args.quiet);
    let options = PhaseRunOptions {
        progress,
        iterations: args.iterations,
        frames: args.frames,
        check_invariants,
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
pub(super) fn resume_protocol_command(
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
pub(super) fn report_protocol(
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
