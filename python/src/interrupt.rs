//! Running engine work without the GIL while Ctrl-C still works.
//!
//! Python runs signal handlers on the main thread only, when that thread
//! calls `PyErr_CheckSignals`. Long engine work therefore runs detached
//! from the interpreter and is handed a `stop()` predicate it asks between
//! ticks. Without a thread pool of its own the work runs on the calling
//! (main) thread, and `stop()` checks signals itself every
//! [`SIGNAL_CHECK_INTERVAL`]. With a pool, the work runs on a pool thread
//! and the calling thread waits, checking signals at the same interval and
//! raising a flag that `stop()` reads.

use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, mpsc};
use std::time::{Duration, Instant};

/// How often pending signals are checked during engine work (a Ctrl-C
/// takes effect within this time plus one tick).
pub const SIGNAL_CHECK_INTERVAL: Duration = Duration::from_millis(20);

/// Runs `work` detached from the interpreter (on `pool` if given) and
/// returns its result with the exception a signal handler raised (e.g.
/// `KeyboardInterrupt`), if `work` was stopped by one.
pub fn run_detached<R: Send>(
    py: Python<'_>,
    pool: Option<&rayon::ThreadPool>,
    work: impl FnOnce(&(dyn Fn() -> bool + Sync)) -> R + Send,
) -> (R, Option<PyErr>) {
    match pool {
        None => py.detach(|| {
            let raised: Mutex<Option<PyErr>> = Mutex::new(None);
            let stopped = AtomicBool::new(false);
            let last = Mutex::new(Instant::now());
            let stop = || {
                if stopped.load(Ordering::Relaxed) {
                    return true;
                }
                {
                    let mut last = last.lock().unwrap_or_else(|p| p.into_inner());
                    if last.elapsed() < SIGNAL_CHECK_INTERVAL {
                        return false;
                    }
                    *last = Instant::now();
                }
                match Python::attach(|py| py.check_signals()) {
                    Ok(()) => false,
                    Err(e) => {
                        *raised.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                        stopped.store(true, Ordering::Relaxed);
                        true
                    }
                }
            };
            let result = work(&stop);
            (
                result,
                raised.into_inner().unwrap_or_else(|p| p.into_inner()),
            )
        }),
        Some(pool) => py.detach(|| {
            let flag = AtomicBool::new(false);
            let (done, finished) = mpsc::channel::<()>();
            let stop_flag = &flag;
            std::thread::scope(|s| {
                // `done` moves in, so a panicking worker also ends the wait.
                let worker = s.spawn(move || {
                    let result = pool.install(|| work(&|| stop_flag.load(Ordering::Relaxed)));
                    let _ = done.send(());
                    result
                });
                let mut raised = None;
                while let Err(mpsc::RecvTimeoutError::Timeout) =
                    finished.recv_timeout(SIGNAL_CHECK_INTERVAL)
                {
                    if raised.is_none()
                        && let Err(e) = Python::attach(|py| py.check_signals())
                    {
                        raised = Some(e);
                        flag.store(true, Ordering::Relaxed);
                    }
                }
                match worker.join() {
                    Ok(result) => (result, raised),
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            })
        }),
    }
}
