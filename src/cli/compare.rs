//! `remembrane compare`: two scenes run one after the other, with a table,
//! a CSV and a chart of their energies, remeshing and wall times side by
//! side (the comparison with Mem3DG is the study's, `src/study/peer.rs`).

use super::*;

/// The arguments of `remembrane compare`.
#[derive(clap::Args)]
pub(super) struct CompareArgs {
    /// First scene (e.g. scenes/vesicle_fusion.ron).
    pub(super) first: PathBuf,
    /// Second scene (e.g. scenes/fusion_geometric.ron).
    pub(super) second: PathBuf,
    /// Iterations for both runs (overrides the scenes').
    #[arg(long)]
    pub(super) iterations: Option<u64>,
    /// Output directory (default out/compare-<first>-<second>); each run
    /// goes into a subfolder named after its scene.
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub(super) overwrite: bool,
    /// Seed for both runs (overrides the scenes').
    #[arg(long)]
    pub(super) seed: Option<u64>,
    /// No progress output.
    #[arg(long)]
    pub(super) quiet: bool,
}

pub(super) fn compare_command(args: CompareArgs) -> ExitCode {
    let CompareArgs {
        first,
        second,
        iterations,
        out,
        overwrite,
        seed,
        quiet,
    } = args;
    let (first, second) = (first.as_path(), second.as_path());
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
            seed,
            iterations,
            progress: if quiet {
                Progress::Quiet
            } else {
                Progress::Lines
            },
            ..RunOptions::quiet(dir.join(name))
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
pub(super) fn free_directory(base: PathBuf) -> PathBuf {
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
