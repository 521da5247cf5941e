//! The discrete-event simulator: actors on a virtual clock, messages timed
//! by a [`NetworkModel`], one thread, deterministic.
//!
//! # Semantics
//!
//! Every actor is a sequential process with an inbox. The event loop pops
//! the earliest pending item (FIFO among equal times) and advances the
//! [`VirtualClock`] to it:
//!
//! - *deliver* an event to an actor: it joins the actor's inbox; if the
//!   actor is not busy it handles its inbox at once;
//! - *ready*: a busy actor's last `Compute` has ended; it handles the events
//!   that queued up meanwhile, in arrival order;
//! - *depart*: a message sent after a `Compute` leaves now (so the network
//!   model sees messages in departure-time order).
//!
//! Handling one event: `handle(now, event)` returns actions, carried out in
//! order with a local time starting at `now`. `Send` hands the message to
//! the cost model at the local time ([`NetworkModel::transfer`]) and
//! schedules its delivery at the arrival time; `Compute(s)` adds `s` to the
//! local time; `Wake(tag)` schedules [`Event::Wake`] at the local time;
//! `Stop` retires the actor. The actor is then busy until its local time.
//!
//! # Determinism
//!
//! No wall clock, no hash maps, no threads: the same actors and model give
//! the same event order, the same floating-point operations in the same
//! order, and therefore bit-identical traces on any machine.

use std::collections::VecDeque;

use super::actor::{Action, Actor, Event};
use super::clock::{Clock, EventQueue, VirtualClock};
use super::cost::{NetState, NetworkModel};
use super::error::{NetError, NetResult};
use super::message::{Envelope, NodeId};
use super::metered::TrafficStats;
use super::trace::{SimTrace, TraceKind};

/// Knobs of a simulation run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimOptions {
    /// Record a [`SimTrace`] (costs memory proportional to the events).
    pub record_trace: bool,
    /// Record idle gaps between an actor's activities in the trace.
    pub record_idle: bool,
    /// Stop with an error after this many loop iterations (guards against
    /// actors that wake themselves forever).
    pub max_events: u64,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            record_trace: true,
            record_idle: true,
            max_events: 100_000_000,
        }
    }
}

/// What a finished simulation reports.
#[derive(Clone, Debug, PartialEq)]
pub struct SimReport {
    /// Virtual time when the last actor finished its last activity.
    pub end_time: f64,
    /// When each actor stopped (`None`: it never sent `Stop`, e.g. it was
    /// still waiting for a message when nothing was left in flight — a
    /// protocol deadlock).
    pub stopped_at: Vec<Option<f64>>,
    /// The timeline (empty unless [`SimOptions::record_trace`]).
    pub trace: SimTrace,
    /// Messages and bytes sent and received, per kind and destination.
    pub traffic: TrafficStats,
    /// Messages addressed to actors that had already stopped.
    pub dropped: u64,
    /// Loop iterations.
    pub events: u64,
}

impl SimReport {
    /// Ranks that never stopped.
    pub fn unfinished(&self) -> Vec<NodeId> {
        self.stopped_at
            .iter()
            .enumerate()
            .filter(|(_, s)| s.is_none())
            .map(|(i, _)| NodeId::from(i))
            .collect()
    }
}

enum Pending {
    Deliver(NodeId, Event),
    Ready(NodeId),
    Depart(Envelope),
}

struct Slot<'a> {
    actor: Box<dyn Actor + 'a>,
    inbox: VecDeque<Event>,
    /// End of the actor's last activity.
    busy_until: f64,
    /// A `Ready` is in the queue for this actor.
    waiting_ready: bool,
    stopped_at: Option<f64>,
}

/// A simulated cluster: actors (index = rank) on a network model.
pub struct Simulation<'a> {
    model: NetworkModel,
    net: NetState,
    slots: Vec<Slot<'a>>,
    queue: EventQueue<Pending>,
    clock: VirtualClock,
    options: SimOptions,
    trace: SimTrace,
    traffic: TrafficStats,
    dropped: u64,
}

impl<'a> Simulation<'a> {
    /// A simulation of `actors` (the `i`-th has rank `i`) on `model`.
    /// Mix actor types with `Box<dyn Actor>`; pass `&mut actor` to keep
    /// access to an actor's state after the run.
    pub fn new<A: Actor + 'a>(model: NetworkModel, actors: impl IntoIterator<Item = A>) -> Self {
        let slots: Vec<Slot<'a>> = actors
            .into_iter()
            .map(|actor| Slot {
                actor: Box::new(actor),
                inbox: VecDeque::new(),
                busy_until: 0.0,
                waiting_ready: false,
                stopped_at: None,
            })
            .collect();
        Simulation {
            model,
            net: NetState::new(slots.len()),
            slots,
            queue: EventQueue::new(),
            clock: VirtualClock::new(),
            options: SimOptions::default(),
            trace: SimTrace::default(),
            traffic: TrafficStats::default(),
            dropped: 0,
        }
    }

    /// Replaces the default options.
    pub fn with_options(mut self, options: SimOptions) -> Self {
        self.options = options;
        self
    }

    /// Runs until nothing is left to happen: every actor has stopped or is
    /// waiting for a message that will never come (see
    /// [`SimReport::unfinished`]). Fails if an actor returns an invalid
    /// action (bad rank, negative or non-finite duration) or the event limit
    /// is hit.
    pub fn run(mut self) -> NetResult<SimReport> {
        for i in 0..self.slots.len() {
            self.queue
                .push(0.0, Pending::Deliver(NodeId::from(i), Event::Start));
        }
        let mut events = 0u64;
        while let Some((t, item)) = self.queue.pop() {
            events += 1;
            if events > self.options.max_events {
                return Err(NetError::Sim(format!(
                    "more than {} events by t = {t} s: an actor may be waking itself forever \
                     (raise SimOptions::max_events if the run is just long)",
                    self.options.max_events
                )));
            }
            self.clock.advance_to(t);
            match item {
                Pending::Deliver(to, event) => {
                    let slot = &mut self.slots[to.index()];
                    if slot.stopped_at.is_some() {
                        self.dropped += 1;
                        continue;
                    }
                    slot.inbox.push_back(event);
                    if !slot.waiting_ready {
                        self.drain(to)?;
                    }
                }
                Pending::Ready(a) => {
                    self.slots[a.index()].waiting_ready = false;
                    self.drain(a)?;
                }
                Pending::Depart(env) => self.depart(env)?,
            }
        }
        let end_time = self
            .slots
            .iter()
            .map(|s| s.busy_until)
            .fold(self.clock.now(), f64::max);
        Ok(SimReport {
            end_time,
            stopped_at: self.slots.iter().map(|s| s.stopped_at).collect(),
            trace: self.trace,
            traffic: self.traffic,
            dropped: self.dropped,
            events,
        })
    }

    /// Lets actor `a` handle its inbox until it is empty or the actor is
    /// busy past the current time.
    fn drain(&mut self, a: NodeId) -> NetResult<()> {
        let now = self.clock.now();
        loop {
            let slot = &mut self.slots[a.index()];
            if slot.stopped_at.is_some() {
                self.dropped += slot.inbox.len() as u64;
                slot.inbox.clear();
                return Ok(());
            }
            let Some(event) = slot.inbox.pop_front() else {
                return Ok(());
            };
            if self.options.record_trace && self.options.record_idle && slot.busy_until < now {
                self.trace.span(a, slot.busy_until, now, TraceKind::Idle);
            }
            let actions = slot.actor.handle(now, event);
            let end = self.perform(a, now, actions)?;
            let slot = &mut self.slots[a.index()];
            slot.busy_until = end;
            if end > now && slot.stopped_at.is_none() {
                slot.waiting_ready = true;
                self.queue.push(end, Pending::Ready(a));
                return Ok(());
            }
        }
    }

    /// Carries out one handler's actions; returns the actor's local time
    /// after them.
    fn perform(&mut self, a: NodeId, now: f64, actions: Vec<Action>) -> NetResult<f64> {
        let mut local = now;
        for action in actions {
            match action {
                Action::Send { to, kind, payload } => {
                    if to.index() >= self.slots.len() {
                        return Err(NetError::NoSuchRank {
                            to,
                            size: self.slots.len(),
                        });
                    }
                    let env = Envelope {
                        from: a,
                        to,
                        kind,
                        payload,
                    };
                    if local > now {
                        self.queue.push(local, Pending::Depart(env));
                    } else {
                        self.depart(env)?;
                    }
                }
                Action::Compute { seconds, activity } => {
                    if !(seconds.is_finite() && seconds >= 0.0) {
                        return Err(NetError::Sim(format!(
                            "{a} asked to compute for {seconds} s ({activity:?}) at t = {now} s; \
                             durations must be finite and >= 0"
                        )));
                    }
                    if self.options.record_trace {
                        self.trace
                            .span(a, local, local + seconds, TraceKind::from(activity));
                    }
                    local += seconds;
                }
                Action::Wake(tag) => self
                    .queue
                    .push(local, Pending::Deliver(a, Event::Wake(tag))),
                Action::Stop => {
                    self.slots[a.index()].stopped_at = Some(local);
                    break;
                }
            }
        }
        Ok(local)
    }

    /// Times a message with the cost model and schedules its delivery.
    fn depart(&mut self, env: Envelope) -> NetResult<()> {
        let t = self.clock.now();
        let bytes = env.len();
        let tr = self
            .model
            .transfer(&mut self.net, env.from, env.to, bytes, t)?;
        self.traffic.record_send(env.to, env.kind, bytes);
        self.traffic.record_recv(env.kind, bytes);
        if self.options.record_trace {
            self.trace.message(
                env.from,
                tr.send_start,
                tr.send_end,
                TraceKind::Send,
                env.to,
                env.kind,
                bytes,
            );
            self.trace.message(
                env.to,
                tr.recv_start,
                tr.arrival,
                TraceKind::Recv,
                env.from,
                env.kind,
                bytes,
            );
        }
        let to = env.to;
        self.queue
            .push(tr.arrival, Pending::Deliver(to, Event::Message(env)));
        Ok(())
    }
}
