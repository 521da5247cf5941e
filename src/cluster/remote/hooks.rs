//! The worker's test hooks ([`Hooks`]): kill (or stop) the process at a
//! chosen point of a frame, a deterministic `kill -9` for the failure
//! tests. Used by the mesh worker ([`super::worker`]) and the grid worker
//! ([`super::grid`]) alike, so it sits below both.

use std::sync::atomic::{AtomicBool, Ordering};

/// Set by the hidden `--test-stop`: the hooks stop the process (SIGSTOP,
/// as `kill -STOP` would) instead of killing it.
pub(in crate::cluster::remote) static HOOK_STOPS: AtomicBool = AtomicBool::new(false);
/// A hook fires once per process (a stopped worker, continued, then
/// serves clean frames).
static HOOK_FIRED: AtomicBool = AtomicBool::new(false);

/// The test hooks' way to fail: SIGKILL, as `kill -9` would, or with
/// `--test-stop` SIGSTOP (the process continues when sent SIGCONT). Only
/// the first hook of a process fires.
pub(in crate::cluster::remote) fn kill_self(why: &str) {
    if HOOK_FIRED.swap(true, Ordering::SeqCst) {
        return;
    }
    let stop = HOOK_STOPS.load(Ordering::SeqCst);
    let (sig, what) = if stop {
        (libc::SIGSTOP, "stopping")
    } else {
        (libc::SIGKILL, "killing")
    };
    crate::cluster::remote::hooks::say(&format!("{what} itself {why}"));
    // SAFETY: getpid and kill have no preconditions; this is a test hook
    // that stops or ends the process on purpose.
    unsafe {
        libc::kill(libc::getpid(), sig);
    }
    if stop {
        crate::cluster::remote::hooks::say(&format!("continued after stopping {why}"));
    }
}

/// The worker's test hooks (see [`super::worker::Worker`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct Hooks {
    /// SIGKILL when the node starts chunk `K + 1` of phase 1.
    pub kill_after_chunks: Option<u64>,
    /// SIGKILL when phase 2 starts.
    pub kill_in_phase2: bool,
    /// SIGKILL when phase 1 of the session's frame `F` starts (frames of
    /// a session counted from 1).
    pub kill_at_frame: Option<u64>,
    /// The session's frame being run (from 1; set by the worker's frame
    /// loop, 0 outside a session).
    pub frame: u64,
}

/// This worker's rank in its session (`u32::MAX`: none yet), named in
/// what it prints.
static RANK: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(u32::MAX);

/// Sets the rank [`say`] names.
pub fn set_rank(rank: u32) {
    RANK.store(rank, Ordering::SeqCst);
}

/// Prints `pvrsim worker R: MSG` on stderr in one write, so that the lines
/// of workers sharing a terminal never splice (`R`: the rank once a
/// session gave one).
pub fn say(msg: &str) {
    use std::io::Write;
    let line = match RANK.load(Ordering::SeqCst) {
        u32::MAX => format!("pvrsim worker: {msg}\n"),
        r => format!("pvrsim worker {r}: {msg}\n"),
    };
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
}

/// A worker's progress (a session, a frame): [`say`] with `-v` only.
pub fn progress(msg: &str) {
    if tracing::enabled!(tracing::Level::INFO) {
        say(msg);
    }
}
