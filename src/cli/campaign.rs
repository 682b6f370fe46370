//! `remembrane study`, `diagram`, `sweep` and `collect`: many runs at once.

use super::*;

/// The arguments of `remembrane sweep`.
#[derive(clap::Args)]
pub(super) struct SweepArgs {
    /// Sweep file (RON), e.g. sweeps/tether.ron.
    pub(super) sweep: PathBuf,
    /// Output directory (default out/<sweep name>).
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// Runs at once (default: number of cores).
    #[arg(long)]
    pub(super) jobs: Option<usize>,
    /// Run only the runs with index ≡ I (mod N), e.g. 3/8.
    #[arg(long, value_name = "I/N")]
    pub(super) shard: Option<String>,
    /// Override every run's iterations (quick trials).
    #[arg(long)]
    pub(super) iterations: Option<u64>,
    /// Print an sbatch job-array script for this sweep instead of running.
    #[arg(long)]
    pub(super) emit_slurm: bool,
    /// Array tasks of the emitted script (default: one per run).
    #[arg(long)]
    pub(super) tasks: Option<usize>,
    /// Run only the sweep's shared phases (the first job of a campaign).
    #[arg(long)]
    pub(super) phases_only: bool,
    /// No per-run progress lines.
    #[arg(long)]
    pub(super) quiet: bool,
}

/// The arguments of `remembrane study`.
#[derive(clap::Args)]
pub(super) struct StudyArgs {
    /// Study file (RON), e.g. scenes/studies/accuracy.ron.
    pub(super) study: PathBuf,
    /// Output directory (default out/<study name>).
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// Cases at once (default 1: wall times are comparable only when
    /// cases do not share the cores).
    #[arg(long, default_value_t = 1)]
    pub(super) jobs: usize,
    /// Only the rungs each problem lists in `quick` (the CI ladder).
    #[arg(long)]
    pub(super) quick: bool,
    /// Do not run the study's peer engines.
    #[arg(long)]
    pub(super) no_peers: bool,
    /// No per-case progress lines.
    #[arg(long)]
    pub(super) quiet: bool,
}

/// `remembrane study`: runs the cases not yet finished, then measures and
/// reports all of them. Exit 2 for a bad study file, 1 if a case failed to
/// run (a run that blew up is a result, not a failure) or the report could
/// not be written.
pub(super) fn study_command(args: StudyArgs) -> ExitCode {
    let StudyArgs {
        study: path,
        out,
        jobs,
        quick,
        no_peers,
        quiet,
    } = args;
    let path = path.as_path();
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

/// The arguments of `remembrane diagram`.
#[derive(clap::Args)]
pub(super) struct DiagramArgs {
    /// Shape-diagram file (RON), e.g. scenes/minimise/shape_diagram.ron.
    pub(super) diagram: PathBuf,
    /// Output directory (default out/<diagram name>).
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub(super) overwrite: bool,
    /// Walk only these meshes (labels, comma-separated).
    #[arg(long, value_delimiter = ',')]
    pub(super) meshes: Option<Vec<String>>,
    /// Override every point's iteration cap (quick trials).
    #[arg(long)]
    pub(super) iterations: Option<u64>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long)]
    pub(super) threads: Option<usize>,
    /// No per-point lines and no table.
    #[arg(long)]
    pub(super) quiet: bool,
}

/// `remembrane diagram FILE` (and `remembrane run FILE` on a shape
/// diagram): exit 2 for a bad file, 1 if a point did not complete (the
/// outputs then stay in OUT.incomplete).
pub(super) fn diagram_command(args: DiagramArgs) -> ExitCode {
    let options = crate::workflow::shape_diagram::DiagramOptions {
        overwrite: args.overwrite,
        meshes: args.meshes,
        iterations: args.iterations,
        progress: !args.quiet,
    };
    run_diagram_file(&args.diagram, args.out, options, args.threads)
}

/// A shape diagram's walk with its options, from `remembrane diagram` or
/// `remembrane run`.
pub(super) fn run_diagram_file(
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

pub(super) fn sweep_command(args: SweepArgs) -> ExitCode {
    use crate::workflow::slurm::{slurm_campaign_script, slurm_script};
    use crate::workflow::sweep::{Sweep, SweepError, SweepOptions, parse_shard, run_sweep};
    let SweepArgs {
        sweep,
        out,
        jobs,
        shard,
        iterations,
        emit_slurm,
        tasks,
        phases_only,
        quiet,
    } = args;
    let sweep_path = sweep.as_path();
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
        Err(e) => return fail(e.to_string()),
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

/// The arguments of `remembrane collect`.
#[derive(clap::Args)]
pub(super) struct CollectArgs {
    /// Sweep output directory (with sweep.json).
    pub(super) dir: PathBuf,
    /// Column on the x axis.
    #[arg(long, default_value = "radius_left_norm")]
    pub(super) x: String,
    /// Column on the y axis.
    #[arg(long, default_value = "radius_right_norm")]
    pub(super) y: String,
    /// Rows of each series.csv used (from the first).
    #[arg(long, default_value_t = 31)]
    pub(super) frames: usize,
    /// Succeed even if some runs have no results yet.
    #[arg(long)]
    pub(super) partial: bool,
}

pub(super) fn collect_command(args: CollectArgs) -> ExitCode {
    let CollectArgs {
        dir,
        x,
        y,
        frames,
        partial,
    } = args;
    let dir = dir.as_path();
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
