//! The actor interface: node and manager logic written once as state
//! machines, run by either driver — the discrete-event simulator
//! ([`crate::net::Simulation`], virtual time, one thread) or the thread
//! driver ([`crate::net::run_threads`], wall time, real transports).
//!
//! An actor never reads a clock and never touches a transport. A driver
//! hands it one [`Event`] at a time with the current time `now`; it answers
//! with the [`Action`]s it takes. See `src/net/README.md` for the protocol
//! between actors and drivers and why it makes both runs agree.
//!
//! ```
//! use pvrsim::net::{Action, Activity, Actor, Event, MessageKind, NodeId};
//!
//! /// Works for 1 ms, tells rank 0, stops.
//! struct Worker;
//! impl Actor for Worker {
//!     fn handle(&mut self, _now: f64, event: Event) -> Vec<Action> {
//!         match event {
//!             Event::Start => vec![
//!                 Action::Compute { seconds: 1e-3, activity: Activity::Scan },
//!                 Action::Send { to: NodeId(0), kind: MessageKind::Control, payload: vec![] },
//!                 Action::Stop,
//!             ],
//!             _ => vec![],
//!         }
//!     }
//! }
//! ```

use serde::{Deserialize, Serialize};

use super::error::NetResult;
use super::message::{Codec, Envelope, Message, MessageKind, NodeId};

/// What happens to an actor.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Event {
    /// The run begins (delivered once, first, at time 0).
    Start,
    /// A message has arrived.
    Message(Envelope),
    /// The actor's own [`Action::Wake`] has come round; the tag is its own.
    Wake(u64),
}

/// What kind of work a [`Action::Compute`] stands for; becomes the span's
/// kind in the trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Activity {
    /// Generic computation.
    Compute,
    /// Scan conversion of cells.
    Scan,
    /// Building or merging ERT tables for sharing.
    Share,
    /// Preparing or absorbing stolen work (load balancing).
    Steal,
    /// Image compositing.
    Composite,
}

/// What an actor does in response to an event. A handler's actions are
/// carried out in order; the actor's local time starts at `now` and only
/// `Compute` advances it.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Send a message; it leaves at the actor's current local time.
    Send {
        /// Destination rank.
        to: NodeId,
        /// Kind, for accounting and dispatch.
        kind: MessageKind,
        /// Encoded payload (see [`crate::net::Codec`]).
        payload: Vec<u8>,
    },
    /// The actor is busy for `seconds`: later actions in the list happen
    /// after it, and events arriving meanwhile wait. The work itself is done
    /// inside `handle`; `seconds` is its modelled cost, from a compute cost
    /// model the actor was built with (the simulator charges it on the
    /// virtual clock; the thread driver may sleep it or ignore it).
    Compute {
        /// Modelled duration (finite, >= 0).
        seconds: f64,
        /// What the time is spent on (for the trace).
        activity: Activity,
    },
    /// Deliver [`Event::Wake`]`(tag)` to this actor at its current local
    /// time, behind any messages that arrived before then. This is how a
    /// long job is cut into chunks with the inbox polled in between.
    Wake(u64),
    /// The actor is finished: no more events are delivered to it, later
    /// messages to it are dropped. Actions after `Stop` are ignored.
    Stop,
}

impl Action {
    /// A `Send` of a typed message.
    pub fn send<M: Message>(codec: &Codec, to: NodeId, msg: &M) -> NetResult<Action> {
        Ok(Action::Send {
            to,
            kind: M::KIND,
            payload: codec.encode(msg)?,
        })
    }
}

/// A node, the manager, or any participant in a protocol.
pub trait Actor {
    /// Reacts to `event` at time `now` (seconds since the start of the
    /// run, virtual or wall) and returns the actions taken, in order.
    fn handle(&mut self, now: f64, event: Event) -> Vec<Action>;
}

impl<A: Actor + ?Sized> Actor for &mut A {
    fn handle(&mut self, now: f64, event: Event) -> Vec<Action> {
        (**self).handle(now, event)
    }
}

impl<A: Actor + ?Sized> Actor for Box<A> {
    fn handle(&mut self, now: f64, event: Event) -> Vec<Action> {
        (**self).handle(now, event)
    }
}
