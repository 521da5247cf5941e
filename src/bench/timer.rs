//! The clocks of `pvrsim calibrate`: the `--timer` choice, a stopwatch on
//! it, and the keep-the-fastest rule every calibration pass shares
//! (below `calibrate.rs` and its `calibrate_*` siblings, so that they do
//! not import each other).

use std::time::Instant;

/// The clock of `--timer`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Timer {
    /// Thread CPU seconds (`CLOCK_THREAD_CPUTIME_ID`).
    Cpu,
    /// Wall seconds.
    Wall,
}

/// A stopwatch on the `--timer` clock.
#[derive(Debug, Clone, Copy)]
pub(super) struct Watch(Timer, Instant, f64);

impl Watch {
    pub(super) fn start(t: Timer) -> Watch {
        Watch(t, Instant::now(), crate::net::cpu::thread_cpu_s())
    }

    pub(super) fn secs(&self) -> f64 {
        match self.0 {
            Timer::Cpu => crate::net::cpu::thread_cpu_s() - self.2,
            Timer::Wall => self.1.elapsed().as_secs_f64(),
        }
    }
}

/// Sample k of `best` keeps the least seconds of itself and sample k of
/// `run` (the same work, timed in another pass); an empty `best` takes
/// `run`.
pub(super) fn keep_fastest<T>(best: &mut Vec<T>, run: Vec<T>, secs: fn(&mut T) -> &mut f64) {
    if best.is_empty() {
        *best = run;
        return;
    }
    for (b, mut r) in best.iter_mut().zip(run) {
        let t = *secs(&mut r);
        let b = secs(b);
        *b = b.min(t);
    }
}
