//! Slurm scripts for a sweep: a job array whose task I runs shard I/N of
//! the sweep (`remembrane sweep --emit-slurm`), and, for a sweep with
//! shared phases, a campaign that submits the phases as one job and the
//! array after it.

use std::path::Path;

/// An sbatch job-array script: task I of `tasks` runs shard I/`tasks` of
/// the sweep with the same binary.
pub fn slurm_script(
    name: &str,
    binary: &Path,
    sweep_path: &Path,
    out: &Path,
    tasks: usize,
) -> String {
    format!(
        "#!/bin/bash\n\
         # Job array for the remembrane sweep `{name}`: task I runs shard I/{tasks}.\n\
         # Submit with: sbatch THIS_FILE; collect with: {bin} collect {out}\n\
         #SBATCH --job-name=remembrane-{name}\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --ntasks=1\n\
         #SBATCH --cpus-per-task=1\n\
         #SBATCH --output={out}/slurm-%A_%a.out\n\
         set -euo pipefail\n\
         mkdir -p {out}\n\
         exec {bin} sweep {sweep} --out {out} --shard \"${{SLURM_ARRAY_TASK_ID}}/{tasks}\" --jobs 1 --quiet\n",
        last = tasks.saturating_sub(1),
        bin = shell_quote(binary),
        sweep = shell_quote(sweep_path),
        out = shell_quote(out),
    )
}

/// A Slurm campaign for a sweep with shared phases, as a shell script that
/// submits the phases as one job and the run array (task I runs shard
/// I/`tasks`) after it with `--dependency=afterok`.
pub fn slurm_campaign_script(
    name: &str,
    binary: &Path,
    sweep_path: &Path,
    out: &Path,
    tasks: usize,
) -> String {
    let array = slurm_script(name, binary, sweep_path, out, tasks);
    format!(
        "#!/bin/bash\n\
         # Slurm campaign for the remembrane sweep `{name}`: its shared phases as one\n\
         # job, then the job array of its runs once the phases have succeeded.\n\
         # Submit with: bash THIS_FILE; collect with: {bin} collect {out}\n\
         set -euo pipefail\n\
         mkdir -p {out}\n\
         phases=$(sbatch --parsable --job-name=remembrane-{name}-phases --ntasks=1 --cpus-per-task=1 \\\n\
         \x20   --output={out}/slurm-phases-%j.out \\\n\
         \x20   --wrap=\"exec {bin} sweep {sweep} --out {out} --phases-only --quiet\")\n\
         array=$(sbatch --parsable --dependency=afterok:\"$phases\" <<'ARRAY'\n\
         {array}ARRAY\n\
         )\n\
         echo \"submitted phases job $phases and run array $array (after $phases)\"\n",
        bin = shell_quote(binary),
        sweep = shell_quote(sweep_path),
        out = shell_quote(out),
    )
}

fn shell_quote(p: &Path) -> String {
    let s = p.display().to_string();
    if s.chars()
        .all(|c| c.is_ascii_alphanumeric() || "/._-+=:".contains(c))
    {
        s
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}
