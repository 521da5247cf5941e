//! The receive loop of the remote transports (TCP and MPI): both hand
//! their I/O thread's items to the actor through a channel, and an item is
//! either a message or link news (a peer's goodbye, a heartbeat) that the
//! transport consumes. [`receive`] waits for the next message in one of the
//! three shapes [`crate::net::Transport`] offers, checking for a lost peer
//! before every wait.

use std::sync::{Mutex, MutexGuard};
use std::time::Instant;

use crossbeam_channel::{Receiver, RecvTimeoutError, TryRecvError};

use super::error::{NetError, NetResult};
use super::message::{Envelope, NodeId};

/// A transport whose incoming items arrive on a channel.
pub(crate) trait Inbox {
    /// What the I/O thread sends.
    type Item;
    /// This rank (named in a disconnection error).
    fn me(&self) -> NodeId;
    /// The channel (an error once the transport is gone).
    fn inbox(&self) -> NetResult<&Receiver<Self::Item>>;
    /// The first peer lost and why (set by the transport when it fails).
    fn failed(&self) -> &Mutex<Option<(String, String)>>;
    /// The message an item carries (recorded in the stats), or `None` for
    /// link news the transport consumed.
    fn take(&self, item: Self::Item) -> NetResult<Option<Envelope>>;
}

/// How long [`receive`] may wait.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Wait {
    /// Until a message arrives.
    Block,
    /// Until this instant (then `Ok(None)`).
    Until(Instant),
    /// Not at all: only what is already queued.
    Poll,
}

/// The next message, within `wait`.
pub(crate) fn receive<T: Inbox>(t: &T, wait: Wait) -> NetResult<Option<Envelope>> {
    let gone = || NetError::Disconnected { rank: t.me() };
    loop {
        check_failed(t)?;
        let inbox = t.inbox()?;
        let item = match wait {
            Wait::Block => inbox.recv().map_err(|_| gone())?,
            Wait::Until(until) => match inbox.recv_deadline(until) {
                Ok(item) => item,
                Err(RecvTimeoutError::Timeout) => return Ok(None),
                Err(RecvTimeoutError::Disconnected) => return Err(gone()),
            },
            Wait::Poll => match inbox.try_recv() {
                Ok(item) => item,
                Err(TryRecvError::Empty) => return Ok(None),
                Err(TryRecvError::Disconnected) => return Err(gone()),
            },
        };
        if let Some(e) = t.take(item)? {
            return Ok(Some(e));
        }
    }
}

/// [`receive`] with [`Wait::Block`]: always a message or an error.
pub(crate) fn receive_blocking<T: Inbox>(t: &T) -> NetResult<Envelope> {
    receive(t, Wait::Block)?.ok_or(NetError::Disconnected { rank: t.me() })
}

/// The error of the first lost peer, if one was lost.
pub(crate) fn check_failed<T: Inbox>(t: &T) -> NetResult<()> {
    match &*lock(t.failed()) {
        Some((peer, reason)) => Err(NetError::PeerLost {
            peer: peer.clone(),
            reason: reason.clone(),
        }),
        None => Ok(()),
    }
}

/// Locks, taking over a poisoned mutex (the transports' state stays
/// consistent: every critical section is a plain update).
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}
