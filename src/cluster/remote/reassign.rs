//! `--on-failure reassign`: when workers are lost at any phase of a frame
//! (set-up, phase 1, collecting results, phase 2), their share of the work
//! goes to the survivors and the frame runs again on them.
//!
//! A worker is *lost* when its set-up failed (unreachable, no answer
//! within the deadline, busy with another coordinator, a bad answer) or
//! when its link to the coordinator ended without `Goodbye` (killed,
//! crashed, silent past the heartbeat deadline, a malformed frame); the
//! survivors give the frame up with a clean `Goodbye` once they notice the
//! loss, so the coordinator tells the two apart
//! ([`RemoteTransport::link_endings`]). Each survivor keeps its share and
//! takes a contiguous part of the lost workers' share ([`reassign_parts`]:
//! cells for mesh frames, bricks for grid frames); the frame then runs
//! from the start on the survivors, with the compositing schedule planned
//! for their number (binary swap with a non-power-of-two group, direct
//! send, radix-k or master, as [`crate::compositor::schedule`] plans any
//! count). This repeats while survivors remain, so a second loss during
//! the retry is handled the same way.
//!
//! What is not kept: the survivors' phase-1 work. The lost worker's
//! lists are gone, phase 1's manager protocol cannot drop a node
//! mid-frame, and phase 2's schedule pairs lists by rank, so every
//! survivor renders its (larger) share again.

use std::time::{Duration, Instant};

pub use crate::cluster::report::transport::{LossEvent, Reassigned};
use crate::net::{NodeId, RemoteTransport};

/// Workers lost in a frame (their set-up failed, or their links ended
/// without `Goodbye`), attached to the error of a failed frame.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LostWorkers {
    /// Their ranks in the failed frame.
    pub ranks: Vec<usize>,
    /// Their names.
    pub names: Vec<String>,
    /// The phase the frame was in (`set-up`, `phase 1`, `collecting
    /// results`, `phase 2`).
    pub phase: String,
}

impl std::fmt::Display for LostWorkers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: lost {}", self.phase, self.names.join(", "))
    }
}

/// The placement after losing `lost`: each survivor keeps its share and
/// takes a contiguous part of the lost workers' share (ascending ids);
/// survivors in rank order become ranks `0..`.
pub fn reassign_parts(parts: &[Vec<u32>], lost: &[usize]) -> Vec<Vec<u32>> {
    let orphans: Vec<u32> = lost
        .iter()
        .flat_map(|&k| parts[k].iter().copied())
        .collect();
    let mut out: Vec<Vec<u32>> = (0..parts.len())
        .filter(|k| !lost.contains(k))
        .map(|k| parts[k].clone())
        .collect();
    let s = out.len().max(1);
    for (i, part) in out.iter_mut().enumerate() {
        let (a, b) = (orphans.len() * i / s, orphans.len() * (i + 1) / s);
        part.extend_from_slice(&orphans[a..b]);
        part.sort_unstable();
    }
    out
}

/// Runs attempts of a frame until one completes: `attempt(workers, parts)`
/// runs the frame on `workers` (indices into the original list) with
/// `parts` (their shares by rank). When an attempt fails with
/// [`LostWorkers`] attached, `reassign` is on and survivors remain, the
/// lost workers' shares go to the survivors and the next attempt runs on
/// them. An attempt that failed while this process itself was not
/// running for half the heartbeat `deadline` or more
/// ([`crate::net::stall`]) is an error that says so, with no
/// reassignment: the workers that gave up on us are not at fault. Returns
/// the outcome and, if any loss happened, what was done.
pub fn with_reassign<T>(
    workers: usize,
    parts: Vec<Vec<u32>>,
    deadline: Duration,
    reassign: bool,
    what: &str,
    mut attempt: impl FnMut(&[usize], &[Vec<u32>]) -> anyhow::Result<T>,
) -> anyhow::Result<(T, Option<Reassigned>)> {
    crate::net::stall::watch();
    let t0 = Instant::now();
    let mut alive: Vec<usize> = (0..workers).collect();
    let mut parts = parts;
    let mut done = Reassigned::default();
    loop {
        let t_attempt = Instant::now();
        let late0 = crate::net::tcp::frame::late_wakeups().0;
        let e = match attempt(&alive, &parts) {
            Ok(x) => {
                let r = (!done.events.is_empty()).then(|| Reassigned {
                    parts: parts.clone(),
                    ..done
                });
                return Ok((x, r));
            }
            Err(e) => e,
        };
        let (late, late_s) = crate::net::tcp::frame::late_wakeups();
        let stalled = crate::net::stall::longest_since(t_attempt);
        if late > late0 || stalled >= deadline / 2 {
            // Not the workers' fault: they heard nothing from us. Nor is
            // a reassignment away from them the cure.
            let s = late_s.max(stalled.as_secs_f64());
            return Err(context(
                e.context(format!(
                    "this coordinator was itself not running for about {s:.1} s during the frame \
                     (stopped, e.g. SIGSTOP, suspended, or starved of CPU); workers that gave up on \
                     it are not at fault: run the frame again"
                )),
                &done,
            ));
        }
        let Some(lost) = e.downcast_ref::<LostWorkers>().cloned() else {
            return Err(context(e, &done));
        };
        if !reassign || lost.ranks.is_empty() || lost.ranks.len() >= alive.len() {
            return Err(context(e, &done));
        }
        let moved: u64 = lost.ranks.iter().map(|&k| parts[k].len() as u64).sum();
        parts = reassign_parts(&parts, &lost.ranks);
        let mut k = 0;
        alive.retain(|_| {
            k += 1;
            !lost.ranks.contains(&(k - 1))
        });
        let error = format!("{e:#}");
        eprintln!(
            "note: {error}\nnote: --on-failure reassign: {moved} {what} of {} go to the {} survivors; the frame runs again on them",
            lost.names.join(", "),
            alive.len()
        );
        if done.first_error.is_empty() {
            done.first_error = error.clone();
        }
        done.lost.extend(lost.names.iter().cloned());
        done.cells += moved;
        let attempt_s = t_attempt.elapsed().as_secs_f64();
        done.recovery_s += attempt_s;
        done.events.push(LossEvent {
            phase: lost.phase.clone(),
            workers: lost.names,
            moved,
            survivors: alive.len(),
            detected_at_s: t0.elapsed().as_secs_f64(),
            attempt_s,
            error,
        });
    }
}

/// The error of the last attempt, after earlier losses were recovered.
fn context(e: anyhow::Error, done: &Reassigned) -> anyhow::Error {
    if done.events.is_empty() {
        e
    } else {
        e.context(format!(
            "the frame on the survivors (--on-failure reassign, after losing {})",
            done.lost.join(", ")
        ))
    }
}

/// How long a failed frame waits for its links to end before it names the
/// lost workers: with `reassign`, until the survivors have surely given up
/// (twice the heartbeat `deadline` plus 2 s, so that every loss is seen
/// before the retry); without, one deadline plus 0.5 s (the dead worker is
/// named, and the error stays within the deadline plus 2 s).
pub(super) fn endings_wait(reassign: bool, deadline: Duration) -> Duration {
    if reassign {
        deadline * 2 + Duration::from_secs(2)
    } else {
        deadline + Duration::from_millis(500)
    }
}

/// `e` with the workers of `t` (worker `k` at rank `off + k`, `k < n`)
/// whose links ended without `Goodbye` attached as [`LostWorkers`] in
/// `phase`, after waiting at most `wait` for the other links to end
/// (unchanged if none was lost: the frame failed for another reason).
pub(super) fn lost_on(
    t: &impl RemoteTransport,
    off: usize,
    n: usize,
    wait: Duration,
    e: anyhow::Error,
    phase: &str,
) -> anyhow::Error {
    let endings = t.link_endings(wait);
    let ranks: Vec<usize> = (0..n)
        .filter(|&k| endings.get(off + k) == Some(&Some(false)))
        .collect();
    if ranks.is_empty() {
        return e;
    }
    let names = ranks
        .iter()
        .map(|&k| t.peer_name(NodeId::from(off + k)))
        .collect();
    e.context(LostWorkers {
        ranks,
        names,
        phase: phase.to_string(),
    })
}
