//! Whether this process itself stopped running for a while: stopped with
//! SIGSTOP, a suspended laptop or VM, or starved of CPU. A peer that gave
//! up on us then is not at fault, and an error must not say it is.
//!
//! [`watch`] starts one watchdog thread per process that sleeps [`TICK`]
//! at a time; a wake-up more than [`RECORD`] late means no thread of the
//! process ran meanwhile (SIGSTOP stops them all), and the gap is kept
//! (the last 64 of them). [`longest_since`] tells a caller whose
//! frame failed how long the process was not running since the frame
//! began. The per-link deadline timers have their own, narrower check
//! (`tcp::frame::late_wakeups`): they only see stalls that hit a wait.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, Once, OnceLock};
use std::time::{Duration, Instant};

/// How often the watchdog wakes.
pub const TICK: Duration = Duration::from_millis(50);
/// How late a wake-up must be to count as a stall.
pub const RECORD: Duration = Duration::from_millis(200);
/// How many stalls are kept.
const KEPT: usize = 64;

static START: Once = Once::new();
/// Stalls: when each ended, and how long it was.
static STALLS: Mutex<VecDeque<(Instant, Duration)>> = Mutex::new(VecDeque::new());
/// When the watchdog started, and when it last woke (microseconds after
/// its start; 0 before the first wake-up).
static EPOCH: OnceLock<Instant> = OnceLock::new();
static LAST_TICK_US: AtomicU64 = AtomicU64::new(0);

/// Starts the watchdog (once per process; later calls do nothing).
pub fn watch() {
    START.call_once(|| {
        let epoch = *EPOCH.get_or_init(Instant::now);
        let spawned = std::thread::Builder::new()
            .name("pvrsim-stall-watch".into())
            .spawn(move || loop {
                let before = Instant::now();
                std::thread::sleep(TICK);
                let late = before.elapsed().saturating_sub(TICK);
                LAST_TICK_US.store(epoch.elapsed().as_micros() as u64, Ordering::Relaxed);
                if late > RECORD {
                    let mut s = super::inbox::lock(&STALLS);
                    if s.len() == KEPT {
                        s.pop_front();
                    }
                    s.push_back((Instant::now(), late));
                }
            });
        // Without the thread (out of threads) stalls go unseen: errors
        // then blame the peers as before, which is no worse.
        drop(spawned);
    });
}

/// The longest stall that ended at or after `t`, or that is ending now
/// (zero if none, or if [`watch`] was never called). A thread that runs
/// again right after SIGCONT may ask before the watchdog has woken: the
/// gap since the watchdog's last wake-up counts then, so the answer does
/// not depend on which thread the scheduler ran first.
pub fn longest_since(t: Instant) -> Duration {
    let recorded = super::inbox::lock(&STALLS)
        .iter()
        .filter(|(end, _)| *end >= t)
        .map(|&(_, d)| d)
        .max()
        .unwrap_or(Duration::ZERO);
    recorded.max(ongoing())
}

/// How much later than due the watchdog's next wake-up already is, if
/// more than [`RECORD`] (zero before its first wake-up).
fn ongoing() -> Duration {
    let (Some(epoch), last) = (EPOCH.get(), LAST_TICK_US.load(Ordering::Relaxed)) else {
        return Duration::ZERO;
    };
    if last == 0 {
        return Duration::ZERO;
    }
    let since = epoch
        .elapsed()
        .saturating_sub(Duration::from_micros(last))
        .saturating_sub(TICK);
    if since > RECORD {
        since
    } else {
        Duration::ZERO
    }
}
