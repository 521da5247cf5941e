//! Cooperative cancellation of a running job (Ctrl-C in the Python module):
//! a process-wide flag that a frontend raises, and [`checkpoint`]s that the
//! long loops call where it is cheap (before each tile of the cell
//! renderer's scan, between a sweep's runs). A checkpoint with the flag up
//! unwinds the job with a [`Cancelled`] payload (`resume_unwind`: no panic
//! message, no hook), which the frontend that raised the flag catches with
//! `catch_unwind`; every guard on the way (worker processes, rayon pools,
//! temporary folders) is dropped as on any unwind. The command line never
//! raises the flag, so its checkpoints are one relaxed load each.

use std::sync::atomic::{AtomicBool, Ordering};

static CANCEL: AtomicBool = AtomicBool::new(false);

/// The payload a cancelled job unwinds with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cancelled;

/// Raises (`true`) or lowers (`false`) the flag for every job in the process.
pub fn set(on: bool) {
    CANCEL.store(on, Ordering::SeqCst);
}

/// Whether the flag is up.
pub fn requested() -> bool {
    CANCEL.load(Ordering::Relaxed)
}

/// Unwinds with [`Cancelled`] when the flag is up; otherwise returns.
pub fn checkpoint() {
    checkpoint_on(&CANCEL);
}

fn checkpoint_on(flag: &AtomicBool) {
    if flag.load(Ordering::Relaxed) {
        std::panic::resume_unwind(Box::new(Cancelled));
    }
}

/// Raises the flag on SIGINT and SIGTERM (the command line's series: the
/// next checkpoint between frames unwinds, and every guard on the way,
/// worker processes and their folders included, is dropped). A second
/// signal ends the process at once (exit 130), as without a handler.
pub fn on_signals() {
    extern "C" fn raise(_: libc::c_int) {
        if CANCEL.swap(true, Ordering::SeqCst) {
            // SAFETY: _exit is async-signal-safe.
            unsafe { libc::_exit(130) }
        }
    }
    let handler = raise as extern "C" fn(libc::c_int) as libc::sighandler_t;
    // SAFETY: the handler only touches an atomic and calls _exit.
    unsafe {
        libc::signal(libc::SIGINT, handler);
        libc::signal(libc::SIGTERM, handler);
    }
}

/// Whether a caught unwind payload is a cancellation.
pub fn is_cancelled(payload: &(dyn std::any::Any + Send)) -> bool {
    payload.is::<Cancelled>()
}

#[cfg(test)]
mod tests {
    use super::*;

    // A flag of the test's own: raising the process-wide one would cancel
    // the renders of tests running beside this one.
    #[test]
    fn a_checkpoint_unwinds_only_while_the_flag_is_up() {
        let flag = AtomicBool::new(false);
        checkpoint_on(&flag);
        flag.store(true, Ordering::SeqCst);
        let r = std::panic::catch_unwind(|| checkpoint_on(&flag));
        assert!(is_cancelled(r.expect_err("cancelled").as_ref()));
        flag.store(false, Ordering::SeqCst);
        checkpoint_on(&flag);
        assert!(!requested());
    }
}
