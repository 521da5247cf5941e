//! Running a job off the GIL, interruptible by Ctrl-C.
//!
//! The job runs on a thread of its own; the calling thread releases the
//! GIL and waits in steps of [`POLL`], taking the GIL back between steps to
//! run Python's signal handlers (`Python::check_signals`). When a handler
//! raises (Ctrl-C: `KeyboardInterrupt`), the cancellation flag
//! ([`pvrsim::base::cancel`]) goes up, the job unwinds at its next
//! checkpoint (each tile of a mesh render, each row or band of a grid
//! render, each event of a simulated cluster frame and each phase-2 round,
//! each frame of a grid series, each run of a sweep), and the exception is
//! raised once the job has stopped, or after [`GRACE`] if it has not (a
//! stretch without checkpoints, e.g. a wall-clock cluster phase, which
//! stops at its end, then finishes in the background; the next job waits
//! for it). A panic never reaches Python: it becomes `RunError`.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use pvrsim::base::cancel;
use pyo3::prelude::*;

/// How often the waiting thread looks for a pending signal.
const POLL: Duration = Duration::from_millis(50);
/// How long a cancelled job is given to stop before the exception is raised.
const GRACE: Duration = Duration::from_millis(900);

/// Jobs started by this module that have not ended yet.
static RUNNING: AtomicUsize = AtomicUsize::new(0);

/// Jobs started by this module that have not ended (a cancelled job
/// counts until it has unwound): the tests check that Ctrl-C stops a job.
#[pyfunction]
pub fn jobs_running() -> usize {
    RUNNING.load(Ordering::SeqCst)
}

/// What the job thread hands back.
type Outcome<T> = std::thread::Result<T>;

/// Runs `job` on its own thread and returns its value; Ctrl-C cancels it
/// and raises `KeyboardInterrupt`, a panic raises `RunError`.
/// `tick`, when given, is called (with the GIL) at every poll step: the
/// package prints a sweep's new rows from it.
pub fn run<T: Send + 'static>(
    py: Python<'_>,
    tick: Option<&Bound<'_, PyAny>>,
    job: impl FnOnce() -> T + Send + 'static,
) -> PyResult<T> {
    // A cancelled job that has not unwound yet still holds the flag up:
    // wait for it (interruptibly) so that it does not cancel this one.
    while cancel::requested() && RUNNING.load(Ordering::SeqCst) > 0 {
        py.allow_threads(|| std::thread::sleep(POLL));
        py.check_signals()?;
    }
    cancel::set(false);
    let (tx, rx) = crossbeam_channel::bounded::<Outcome<T>>(1);
    RUNNING.fetch_add(1, Ordering::SeqCst);
    let spawned = std::thread::Builder::new()
        .name("pvrsim-job".into())
        .spawn(move || {
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(job));
            let _ = tx.send(r);
            if RUNNING.fetch_sub(1, Ordering::SeqCst) == 1 {
                cancel::set(false);
            }
        });
    if let Err(e) = spawned {
        RUNNING.fetch_sub(1, Ordering::SeqCst);
        return Err(crate::errors::raise(
            py,
            "RunError",
            format!("cannot start the job's thread: {e}"),
            &[],
        ));
    }
    loop {
        match py.allow_threads(|| rx.recv_timeout(POLL)) {
            Ok(r) => return outcome(py, r),
            Err(crossbeam_channel::RecvTimeoutError::Timeout) => {
                let polled = py
                    .check_signals()
                    .and_then(|()| tick.map_or(Ok(()), |t| t.call0().map(drop)));
                if let Err(e) = polled {
                    cancel::set(true);
                    // Give the job a moment to unwind; its result is moot.
                    let _ = py.allow_threads(|| rx.recv_timeout(GRACE));
                    return Err(e);
                }
            }
            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => {
                return Err(crate::errors::raise(
                    py,
                    "RunError",
                    "internal error: the job's thread ended without a result".into(),
                    &[],
                ))
            }
        }
    }
}

/// The job's value, or the exception its unwinding stands for.
fn outcome<T>(py: Python<'_>, r: Outcome<T>) -> PyResult<T> {
    match r {
        Ok(v) => Ok(v),
        Err(p) if cancel::is_cancelled(p.as_ref()) => Err(
            pyo3::exceptions::PyKeyboardInterrupt::new_err("the job was cancelled"),
        ),
        Err(p) => Err(crate::errors::raise(
            py,
            "RunError",
            format!(
                "internal error: the job panicked: {} (please report it)",
                crate::errors::panic_text(p.as_ref())
            ),
            &[],
        )),
    }
}
