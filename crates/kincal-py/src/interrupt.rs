//! Long calls that stay responsive: the work runs on a worker thread with the GIL released,
//! and the calling thread wakes every [`POLL`] to check for signals (Ctrl-C:
//! `KeyboardInterrupt`) and call a progress callback. The first exception asks the work to
//! stop (a flag it watches between chunks) and is raised as it was once the work returned.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use pyo3::prelude::*;

/// How often the calling thread wakes while the work runs.
pub(crate) const POLL: Duration = Duration::from_millis(50);

/// Runs `work` on a worker thread with the GIL released. Every [`POLL`] (and once after
/// `work` returned) the calling thread checks for signals and calls `tick`; the first
/// exception of either sets `stop`, which `work` must watch, is not followed by further
/// checks, and is returned once `work` has returned (its result then dropped).
pub(crate) fn run_interruptible<T: Send>(
    py: Python<'_>,
    stop: &AtomicBool,
    work: impl FnOnce() -> T + Send,
    mut tick: impl FnMut() -> PyResult<()>,
) -> PyResult<T> {
    let mut raised: Option<PyErr> = None;
    let result = std::thread::scope(|scope| {
        let worker = scope.spawn(work);
        loop {
            let finished = py.detach(|| {
                let until = Instant::now() + POLL;
                while !worker.is_finished() && Instant::now() < until {
                    std::thread::sleep(Duration::from_millis(2));
                }
                worker.is_finished()
            });
            if raised.is_none()
                && let Err(e) = py.check_signals().and_then(|()| tick())
            {
                raised = Some(e);
                stop.store(true, Ordering::Relaxed);
            }
            if finished {
                break;
            }
        }
        worker.join()
    });
    match (raised, result) {
        (Some(e), _) => Err(e),
        (None, Ok(r)) => Ok(r),
        (None, Err(panic)) => std::panic::resume_unwind(panic),
    }
}

/// Runs `work`, which cannot stop early (one identification), on a detached worker thread
/// with the GIL released, checking for signals every [`POLL`]: Ctrl-C raises
/// `KeyboardInterrupt` at once and the worker finishes in the background, its result dropped
/// (it holds no Python object and writes nothing). A panic of `work` is resumed here.
pub(crate) fn run_abandonable<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce() -> PyResult<T> + Send + 'static,
) -> PyResult<T> {
    use std::sync::mpsc::{RecvTimeoutError, channel};
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
        let _ = tx.send(r);
    });
    let mut rx = rx;
    loop {
        // The receiver is Send, not Sync: moved into the wait and back.
        let (got, back) = py.detach(move || (rx.recv_timeout(POLL), rx));
        rx = back;
        match got {
            Ok(Ok(r)) => return r,
            Ok(Err(panic)) => std::panic::resume_unwind(panic),
            Err(RecvTimeoutError::Timeout) => py.check_signals()?,
            Err(RecvTimeoutError::Disconnected) => {
                unreachable!("the worker sends its result before it ends")
            }
        }
    }
}
