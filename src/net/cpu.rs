//! CPU clocks: the seconds of CPU a thread (or the whole process) has used,
//! beside the wall clock. On a host whose cores are shared (more nodes than
//! cores, other jobs), wall time includes the time a node waited for a
//! core; its thread's CPU time does not, so CPU time is what a modelled
//! compute cost is compared with (`pvrsim fidelity`).
//!
//! The thread driver ([`crate::net::run_actor`]) reads the thread CPU clock
//! around every `handle` call and records one [`CpuSample`] per
//! [`crate::net::Action::Compute`] in [`crate::net::SimTrace::cpu`]: the
//! compute action's modelled seconds, and the wall and CPU seconds the call
//! took (split over the call's compute actions in proportion to their
//! modelled seconds when there are several).

use super::message::NodeId;
pub use super::trace::CpuSample;
use super::trace::TraceKind;

fn clock_s(id: libc::clockid_t) -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; clock_gettime only writes it.
    let rc = unsafe { libc::clock_gettime(id, &mut ts) };
    if rc != 0 {
        return 0.0;
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// CPU seconds used so far by the calling thread (`CLOCK_THREAD_CPUTIME_ID`).
pub fn thread_cpu_s() -> f64 {
    clock_s(libc::CLOCK_THREAD_CPUTIME_ID)
}

/// CPU seconds used so far by the whole process, all threads
/// (`CLOCK_PROCESS_CPUTIME_ID`).
pub fn process_cpu_s() -> f64 {
    clock_s(libc::CLOCK_PROCESS_CPUTIME_ID)
}

/// Minor page faults (no I/O) the process has taken so far
/// (`getrusage(RUSAGE_SELF)`). A fresh process's first touch of its memory
/// is one fault a page, at a price set by the host (far higher in a
/// micro-VM whose guest memory is backed lazily) rather than by the work;
/// the count tells how much of a render's CPU time may be that. (The
/// user/system split of `getrusage` is not used: with tick-based CPU
/// accounting it is sampled every 4 ms, too coarse for a 10 ms render.)
pub fn minor_faults() -> u64 {
    // SAFETY: an all-zero rusage is a valid value; getrusage only writes it.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `ru` is a valid, writable rusage.
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) } != 0 {
        return 0;
    }
    ru.ru_minflt.max(0) as u64
}

/// Peak resident memory of the calling process so far, in bytes
/// (`getrusage(RUSAGE_SELF).ru_maxrss`, which Linux counts in KiB: the
/// same figure as `VmHWM` in `/proc/self/status` and `/usr/bin/time -v`'s
/// "Maximum resident set size"); `None` if the call fails.
pub fn peak_rss_bytes() -> Option<u64> {
    // SAFETY: an all-zero rusage is a valid value; getrusage only writes it.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `ru` is a valid, writable rusage.
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) } != 0 {
        return None;
    }
    u64::try_from(ru.ru_maxrss).ok().map(|kib| kib * 1024)
}

/// Splits a call's measured `wall` and `cpu` seconds over its compute
/// actions `(kind, modelled seconds)`, in proportion to the modelled
/// seconds (evenly if they are all 0).
pub fn split_call(
    node: NodeId,
    start: f64,
    actions: &[(TraceKind, f64)],
    wall: f64,
    cpu: f64,
) -> Vec<CpuSample> {
    let total: f64 = actions.iter().map(|a| a.1).sum();
    let n = actions.len().max(1) as f64;
    actions
        .iter()
        .map(|&(kind, m)| {
            let f = if total > 0.0 { m / total } else { 1.0 / n };
            CpuSample {
                node,
                kind,
                start,
                modelled_s: m,
                wall_s: wall * f,
                cpu_s: cpu * f,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thread_cpu_advances_with_work_not_with_sleep() {
        let a = thread_cpu_s();
        std::thread::sleep(std::time::Duration::from_millis(30));
        let slept = thread_cpu_s() - a;
        let b = thread_cpu_s();
        let mut x = 0u64;
        let t = std::time::Instant::now();
        while t.elapsed().as_millis() < 30 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let worked = thread_cpu_s() - b;
        assert!(slept < 0.01, "sleeping used {slept} s of CPU");
        assert!(worked > 0.001, "30 ms of spinning used {worked} s of CPU");
        assert!(process_cpu_s() >= worked);
    }

    #[test]
    fn split_is_proportional_to_the_model() {
        let s = split_call(
            NodeId(1),
            0.5,
            &[(TraceKind::Scan, 3.0), (TraceKind::Share, 1.0)],
            2.0,
            1.0,
        );
        assert_eq!(s.len(), 2);
        assert!((s[0].cpu_s - 0.75).abs() < 1e-12 && (s[1].wall_s - 0.5).abs() < 1e-12);
        let even = split_call(NodeId(0), 0.0, &[(TraceKind::Scan, 0.0); 2], 1.0, 1.0);
        assert!((even[0].cpu_s - 0.5).abs() < 1e-12);
    }
}
