//! Counting at the boundary (as IceT adds to `ICET_BYTES_SENT` in its
//! communication layer, never inside the algorithms): [`Metered`] wraps any
//! [`Transport`] and tallies messages and payload bytes per
//! [`MessageKind`] and per destination. The discrete-event simulator fills
//! the same [`TrafficStats`], so reports compare across drivers.
//!
//! Bytes are *payload* bytes (what the application handed to `send`);
//! headers and framing are the cost model's business
//! ([`crate::net::NetworkModel`]).

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::Duration;

use serde::{Deserialize, Serialize};

use super::error::NetResult;
use super::message::{Envelope, MessageKind, NodeId};
use super::transport::Transport;

/// A message count and a byte count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counter {
    /// Number of messages.
    pub messages: u64,
    /// Payload bytes.
    pub bytes: u64,
}

impl Counter {
    fn add(&mut self, bytes: u64) {
        self.messages += 1;
        self.bytes += bytes;
    }

    fn merge(&mut self, other: &Counter) {
        self.messages += other.messages;
        self.bytes += other.bytes;
    }
}

/// Traffic seen by one endpoint (or, merged, by the whole network).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TrafficStats {
    /// Sent, per kind.
    pub sent_by_kind: BTreeMap<MessageKind, Counter>,
    /// Received, per kind.
    pub recv_by_kind: BTreeMap<MessageKind, Counter>,
    /// Sent, per destination rank (index = rank).
    pub sent_by_dest: Vec<Counter>,
}

impl TrafficStats {
    /// Records one sent message.
    pub fn record_send(&mut self, to: NodeId, kind: MessageKind, bytes: u64) {
        self.sent_by_kind.entry(kind).or_default().add(bytes);
        if self.sent_by_dest.len() <= to.index() {
            self.sent_by_dest.resize(to.index() + 1, Counter::default());
        }
        self.sent_by_dest[to.index()].add(bytes);
    }

    /// Records one received message.
    pub fn record_recv(&mut self, kind: MessageKind, bytes: u64) {
        self.recv_by_kind.entry(kind).or_default().add(bytes);
    }

    /// Total sent over all kinds.
    pub fn total_sent(&self) -> Counter {
        let mut c = Counter::default();
        for v in self.sent_by_kind.values() {
            c.merge(v);
        }
        c
    }

    /// Adds another endpoint's counts to these.
    pub fn merge(&mut self, other: &TrafficStats) {
        for (k, v) in &other.sent_by_kind {
            self.sent_by_kind.entry(*k).or_default().merge(v);
        }
        for (k, v) in &other.recv_by_kind {
            self.recv_by_kind.entry(*k).or_default().merge(v);
        }
        if self.sent_by_dest.len() < other.sent_by_dest.len() {
            self.sent_by_dest
                .resize(other.sent_by_dest.len(), Counter::default());
        }
        for (a, b) in self.sent_by_dest.iter_mut().zip(&other.sent_by_dest) {
            a.merge(b);
        }
    }
}

/// A transport that counts what passes through it.
pub struct Metered<T> {
    inner: T,
    stats: Mutex<TrafficStats>,
}

impl<T: Transport> Metered<T> {
    /// Wraps `inner` with zeroed counters.
    pub fn new(inner: T) -> Self {
        Metered {
            inner,
            stats: Mutex::new(TrafficStats::default()),
        }
    }

    /// A copy of the counters so far.
    pub fn stats(&self) -> TrafficStats {
        self.lock().clone()
    }

    /// The wrapped transport.
    pub fn into_inner(self) -> T {
        self.inner
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, TrafficStats> {
        // A panic while holding the lock leaves plain counters behind; they
        // are still meaningful, so poisoning is ignored.
        self.stats.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn seen(&self, e: Option<Envelope>) -> Option<Envelope> {
        if let Some(env) = &e {
            self.lock().record_recv(env.kind, env.len());
        }
        e
    }
}

impl<T: Transport> Transport for Metered<T> {
    fn rank(&self) -> NodeId {
        self.inner.rank()
    }

    fn size(&self) -> usize {
        self.inner.size()
    }

    fn send(&self, to: NodeId, kind: MessageKind, payload: Vec<u8>) -> NetResult<()> {
        let n = payload.len() as u64;
        self.inner.send(to, kind, payload)?;
        self.lock().record_send(to, kind, n);
        Ok(())
    }

    fn recv(&self) -> NetResult<Envelope> {
        let e = self.inner.recv()?;
        self.lock().record_recv(e.kind, e.len());
        Ok(e)
    }

    fn recv_timeout(&self, timeout: Duration) -> NetResult<Option<Envelope>> {
        Ok(self.seen(self.inner.recv_timeout(timeout)?))
    }

    fn try_recv(&self) -> NetResult<Option<Envelope>> {
        Ok(self.seen(self.inner.try_recv()?))
    }
}
