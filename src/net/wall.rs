//! The thread driver: each actor on its own thread, talking through a real
//! [`Transport`], on wall-clock time. Same actors, same [`Action`]
//! semantics as the simulator (see `src/net/README.md`):
//!
//! - `Send` becomes `transport.send`;
//! - `Compute(s)`: the work was done inside `handle`; the driver either
//!   sleeps `s` ([`ComputeMode::Sleep`], to emulate a modelled cost) or
//!   moves on ([`ComputeMode::Skip`], when `handle` really did the work);
//! - `Wake(tag)`: first pulls every message already in the transport into
//!   the actor's local queue, then appends the wake, so it comes after the
//!   messages that arrived before it — as in the simulator;
//! - `Stop` ends the thread. Messages sent to it later stay unread.
//!
//! A blocked receive gives up after [`WallOptions::recv_timeout`], so a
//! protocol deadlock is an error, not a hang.

use std::collections::VecDeque;
use std::time::Duration;

use super::actor::{Action, Actor, Event};
use super::clock::{Clock, WallClock};
use super::error::{NetError, NetResult};
use super::metered::TrafficStats;
use super::trace::{SimTrace, TraceKind};
use super::transport::Transport;

/// What the thread driver does with [`Action::Compute`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ComputeMode {
    /// Sleep for the modelled duration (emulates a cost model in real time).
    Sleep,
    /// Do nothing: `handle` did the real work and took real time.
    Skip,
}

/// Knobs of a threaded run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallOptions {
    /// Treatment of `Compute` actions.
    pub compute: ComputeMode,
    /// Longest wait for a message before the run fails with
    /// [`NetError::Timeout`].
    pub recv_timeout: Duration,
}

impl Default for WallOptions {
    fn default() -> Self {
        WallOptions {
            compute: ComputeMode::Skip,
            recv_timeout: Duration::from_secs(30),
        }
    }
}

/// What a finished threaded run reports.
#[derive(Clone, Debug, PartialEq)]
pub struct WallReport {
    /// Wall seconds from start until the last actor stopped.
    pub end_time: f64,
    /// When each actor stopped.
    pub stopped_at: Vec<f64>,
    /// The timeline in wall seconds (compute, idle, and zero-length send and
    /// receive marks: real NIC times are not observable here).
    pub trace: SimTrace,
    /// Messages and bytes per kind and destination, merged over ranks.
    pub traffic: TrafficStats,
}

/// Runs actor `i` on `transports[i]`, each on its own scoped thread, until
/// every actor has stopped. `transports` stay alive for the whole run, so a
/// send to a stopped actor succeeds (and is never read), as in the
/// simulator.
pub fn run_threads<T, A>(
    transports: &[T],
    actors: impl IntoIterator<Item = A>,
    options: WallOptions,
) -> NetResult<WallReport>
where
    T: Transport + Sync,
    A: Actor + Send,
{
    let actors: Vec<A> = actors.into_iter().collect();
    if transports.len() != actors.len() {
        return Err(NetError::Sim(format!(
            "{} actors for {} transports; give one actor per rank",
            actors.len(),
            transports.len()
        )));
    }
    let clock = WallClock::start();
    let results: Vec<NetResult<(f64, SimTrace, TrafficStats)>> = std::thread::scope(|s| {
        let handles: Vec<_> = transports
            .iter()
            .zip(actors)
            .map(|(t, actor)| s.spawn(move || run_actor(t, actor, clock, options)))
            .collect();
        handles
            .into_iter()
            .zip(transports)
            .map(|(h, t)| h.join().unwrap_or(Err(NetError::ThreadPanic(t.rank()))))
            .collect()
    });
    let mut report = WallReport {
        end_time: 0.0,
        stopped_at: Vec::with_capacity(results.len()),
        trace: SimTrace::default(),
        traffic: TrafficStats::default(),
    };
    for r in results {
        let (stop, trace, traffic) = r?;
        report.end_time = report.end_time.max(stop);
        report.stopped_at.push(stop);
        report.trace.events.extend(trace.events);
        report.trace.cpu.extend(trace.cpu);
        report.traffic.merge(&traffic);
    }
    report
        .trace
        .events
        .sort_by(|a, b| a.start.total_cmp(&b.start).then(a.node.cmp(&b.node)));
    Ok(report)
}

/// One actor's loop on the calling thread until it stops; returns its stop
/// time, trace and traffic. This is what each thread of [`run_threads`]
/// runs, and what a process driver (one actor per process, over TCP) calls.
pub fn run_actor<T: Transport, A: Actor>(
    t: &T,
    mut actor: A,
    clock: WallClock,
    options: WallOptions,
) -> NetResult<(f64, SimTrace, TrafficStats)> {
    let me = t.rank();
    let mut trace = SimTrace::default();
    let mut traffic = TrafficStats::default();
    let mut local: VecDeque<Event> = VecDeque::from([Event::Start]);
    let mut last_end = 0.0;
    let pull = |local: &mut VecDeque<Event>| -> NetResult<()> {
        while let Some(e) = t.try_recv()? {
            local.push_back(Event::Message(e));
        }
        Ok(())
    };
    loop {
        pull(&mut local)?;
        let event = match local.pop_front() {
            Some(e) => e,
            None => match t.recv_timeout(options.recv_timeout)? {
                Some(e) => Event::Message(e),
                None => {
                    return Err(NetError::Timeout {
                        rank: me,
                        seconds: options.recv_timeout.as_secs_f64(),
                    })
                }
            },
        };
        let now = clock.now();
        if now > last_end {
            trace.span(me, last_end, now, TraceKind::Idle);
        }
        if let Event::Message(e) = &event {
            traffic.record_recv(e.kind, e.len());
            trace.message(me, now, now, TraceKind::Recv, e.from, e.kind, e.len());
        }
        let cpu0 = super::cpu::thread_cpu_s();
        let actions = actor.handle(now, event);
        let handled = clock.now();
        let cpu = super::cpu::thread_cpu_s() - cpu0;
        if options.compute == ComputeMode::Skip {
            let computes: Vec<(TraceKind, f64)> = actions
                .iter()
                .filter_map(|a| match a {
                    Action::Compute { seconds, activity } => Some(((*activity).into(), *seconds)),
                    _ => None,
                })
                .collect();
            if !computes.is_empty() {
                trace.cpu.extend(super::cpu::split_call(
                    me,
                    now,
                    &computes,
                    handled - now,
                    cpu,
                ));
            }
        }
        for action in actions {
            match action {
                Action::Send { to, kind, payload } => {
                    let n = payload.len() as u64;
                    let at = clock.now();
                    t.send(to, kind, payload)?;
                    traffic.record_send(to, kind, n);
                    trace.message(me, at, at, TraceKind::Send, to, kind, n);
                }
                Action::Compute { seconds, activity } => {
                    if !(seconds.is_finite() && seconds >= 0.0) {
                        return Err(NetError::Sim(format!(
                            "{me} asked to compute for {seconds} s; durations must be finite and >= 0"
                        )));
                    }
                    match options.compute {
                        ComputeMode::Sleep => {
                            let start = clock.now();
                            std::thread::sleep(Duration::from_secs_f64(seconds));
                            trace.span(me, start, clock.now(), activity.into());
                        }
                        ComputeMode::Skip => trace.span(me, now, handled, activity.into()),
                    }
                }
                Action::Wake(tag) => {
                    pull(&mut local)?;
                    local.push_back(Event::Wake(tag));
                }
                Action::Stop => return Ok((clock.now(), trace, traffic)),
            }
        }
        last_end = clock.now();
    }
}
