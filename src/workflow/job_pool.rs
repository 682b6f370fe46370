//! Independent jobs on a fixed number of worker threads (the runs of a
//! sweep, the cases of a study), each on its own rayon pool so that a job's
//! results do not depend on how many run beside it, with one progress line
//! per finished job.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Why a job failed.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The job's rayon pool could not be started.
    #[error("cannot start the thread pool: {0}")]
    ThreadPool(#[from] rayon::ThreadPoolBuildError),
    /// The job itself failed (its error, as the user reads it).
    #[error("{0}")]
    Failed(String),
}

impl From<String> for JobError {
    fn from(reason: String) -> Self {
        JobError::Failed(reason)
    }
}

impl From<&str> for JobError {
    fn from(reason: &str) -> Self {
        JobError::Failed(reason.to_string())
    }
}

/// Runs `work` for every job, `workers` at a time, in order of the list.
/// Job `k` runs on a rayon pool of `threads(k)` threads; `work` returns the
/// job's wall time (s) or why it failed. Unless `quiet`, each finished job
/// prints `[k/n] NAME: done in … s` (or `FAILED: …`) to stderr, its name
/// being `name(k)`. No job starts once `cancel` returns true. Returns the
/// count of jobs that finished and the failed ones with their errors,
/// sorted by name.
pub fn run_jobs(
    count: usize,
    workers: usize,
    quiet: bool,
    cancel: &(dyn Fn() -> bool + Sync),
    name: &(dyn Fn(usize) -> PathBuf + Sync),
    threads: &(dyn Fn(usize) -> usize + Sync),
    work: &(dyn Fn(usize) -> Result<f64, JobError> + Sync),
) -> (usize, Vec<(PathBuf, String)>) {
    let next = AtomicUsize::new(0);
    let results = Mutex::new(Vec::new());
    let started = Instant::now();
    let worker = || {
        while !cancel() {
            let k = next.fetch_add(1, Ordering::Relaxed);
            if k >= count {
                break;
            }
            let result = match rayon::ThreadPoolBuilder::new()
                .num_threads(threads(k))
                .build()
            {
                Ok(pool) => pool.install(|| work(k)),
                Err(e) => Err(JobError::ThreadPool(e)),
            };
            let job = name(k);
            if !quiet {
                report(k, count, &job, &result, started);
            }
            results
                .lock()
                .expect("no worker panicked")
                .push((job, result));
        }
    };
    std::thread::scope(|s| {
        for _ in 0..workers.max(1).min(count.max(1)) {
            s.spawn(worker);
        }
    });
    let results = results.into_inner().expect("no worker panicked");
    let completed = results.iter().filter(|r| r.1.is_ok()).count();
    let mut failed: Vec<(PathBuf, String)> = results
        .into_iter()
        .filter_map(|(job, r)| r.err().map(|e| (job, e.to_string())))
        .collect();
    failed.sort();
    (completed, failed)
}

fn report(k: usize, count: usize, job: &Path, result: &Result<f64, JobError>, started: Instant) {
    match result {
        Ok(wall) => eprintln!(
            "[{}/{count}] {}: done in {wall:.2} s ({:.0} s elapsed)",
            k + 1,
            job.display(),
            started.elapsed().as_secs_f64()
        ),
        Err(e) => eprintln!("[{}/{count}] {}: FAILED: {e}", k + 1, job.display()),
    }
}
