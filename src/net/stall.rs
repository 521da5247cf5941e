//! Whether this process itself stopped running for a while: stopped with
//! SIGSTOP, a suspended laptop or VM, or starved of CPU. A peer that gave
//! up on us then is not at fault, and an error must not say it is.
//!
//! [`watch`] starts one watchdog thread per process that sleeps [`TICK`]
//! at a time; a wake-up more than [`RECORD`] late means no thread of the
//! process ran meanwhile (SIGSTOP stops them all), and the gap is kept
//! (the last [`KEPT`] of them). [`longest_since`] tells a caller whose
//! frame failed how long the process was not running since the frame
//! began. The per-link deadline timers have their own, narrower check
//! (`tcp::frame::late_wakeups`): they only see stalls that hit a wait.

use std::collections::VecDeque;
use std::sync::{Mutex, Once};
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

/// Starts the watchdog (once per process; later calls do nothing).
pub fn watch() {
    START.call_once(|| {
        let spawned = std::thread::Builder::new()
            .name("pvrsim-stall-watch".into())
            .spawn(|| loop {
                let before = Instant::now();
                std::thread::sleep(TICK);
                let late = before.elapsed().saturating_sub(TICK);
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

/// The longest stall that ended at or after `t` (zero if none, or if
/// [`watch`] was never called).
pub fn longest_since(t: Instant) -> Duration {
    super::inbox::lock(&STALLS)
        .iter()
        .filter(|(end, _)| *end >= t)
        .map(|&(_, d)| d)
        .max()
        .unwrap_or(Duration::ZERO)
}
