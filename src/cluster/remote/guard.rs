//! [`SessionGuard`]: the transport an actor sees in a worker process or in
//! the coordinator. It passes the actors' messages through and keeps
//! session messages (kind `Session`) away from them: a peer's failure
//! report becomes an error naming that peer; on a worker, messages that
//! peers sent before this worker's `Go` are handed out first. And
//! [`given_up_while_stopped`]: a worker's check, before its frame's last
//! message, that the coordinator did not give the frame up while the
//! worker itself was not running.

use std::collections::VecDeque;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use super::session::Session;
use crate::net::{
    Codec, Envelope, MessageKind, NetError, NetResult, NodeId, RemoteTransport, Transport,
};

/// See the module docs.
pub struct SessionGuard<'a, T: RemoteTransport> {
    inner: &'a T,
    codec: Codec,
    kept: Mutex<VecDeque<Envelope>>,
}

impl<'a, T: RemoteTransport> SessionGuard<'a, T> {
    /// Guards `t` (the coordinator's side).
    pub fn new(t: &'a T, codec: Codec) -> Self {
        SessionGuard {
            inner: t,
            codec,
            kept: Mutex::new(VecDeque::new()),
        }
    }

    /// Waits for `Go` from `coord` (a worker's side), keeping the actors'
    /// messages that arrive before it.
    pub fn wait_go(t: &'a T, coord: NodeId, codec: Codec, wait: Duration) -> anyhow::Result<Self> {
        let g = SessionGuard::new(t, codec);
        loop {
            let e = t
                .recv_timeout(wait)?
                .ok_or_else(|| anyhow::anyhow!("no Go from the coordinator within {wait:?}"))?;
            if e.kind == MessageKind::Session {
                match codec.decode::<Session>(&e.payload) {
                    Ok(Session::Go) if e.from == coord => return Ok(g),
                    _ => {
                        g.check(e)?;
                    }
                }
            } else {
                g.kept
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .push_back(e);
            }
        }
    }

    /// An actor message passes; a session message is an error.
    fn check(&self, e: Envelope) -> NetResult<Envelope> {
        if e.kind != MessageKind::Session {
            return Ok(e);
        }
        let peer = self.inner.peer_name(e.from);
        let reason = match self.codec.decode::<Session>(&e.payload) {
            Ok(Session::Lost(ranks)) => {
                let (peer, reason) = take_blame(self.inner, e.from, &ranks);
                return Err(NetError::PeerLost { peer, reason });
            }
            Ok(Session::Failed(why)) => format!("failed: {why}"),
            Ok(other) => format!("sent {} out of turn", variant(&other)),
            Err(err) => format!("sent a bad session message: {err}"),
        };
        Err(NetError::PeerLost { peer, reason })
    }

    fn pop(&self) -> Option<Envelope> {
        self.kept
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .pop_front()
    }
}

fn variant(s: &Session) -> &'static str {
    match s {
        Session::Setup(_) => "a set-up",
        Session::Need(_) => "a cache answer",
        Session::Cells(_) => "cells",
        Session::Ready { .. } => "Ready",
        Session::Go => "Go",
        Session::Result(_) => "its result",
        Session::Failed(_) => "a failure",
        Session::Composite => "the start of phase 2",
        Session::Phase2Done(_) => "its phase-2 log",
        Session::Grid(_) => "a grid message",
        Session::End => "the end of the session",
        Session::Flush => "a flush",
        Session::Lost(_) => "a report of lost peers",
    }
}

impl<T: RemoteTransport> Transport for SessionGuard<'_, T> {
    fn rank(&self) -> NodeId {
        self.inner.rank()
    }
    fn size(&self) -> usize {
        self.inner.size()
    }
    fn send(&self, to: NodeId, kind: MessageKind, payload: Vec<u8>) -> NetResult<()> {
        self.inner.send(to, kind, payload)
    }
    fn recv(&self) -> NetResult<Envelope> {
        match self.pop() {
            Some(e) => Ok(e),
            None => self.check(self.inner.recv()?),
        }
    }
    fn recv_timeout(&self, timeout: Duration) -> NetResult<Option<Envelope>> {
        match self.pop() {
            Some(e) => Ok(Some(e)),
            None => self
                .inner
                .recv_timeout(timeout)?
                .map(|e| self.check(e))
                .transpose(),
        }
    }
    fn try_recv(&self) -> NetResult<Option<Envelope>> {
        match self.pop() {
            Some(e) => Ok(Some(e)),
            None => self.inner.try_recv()?.map(|e| self.check(e)).transpose(),
        }
    }
}

/// How long a worker that was itself not running waits for the
/// coordinator's word before its frame's last message.
pub const STALL_CHECK: Duration = Duration::from_secs(1);

/// Before a worker's last message of a frame (its result, its phase-2
/// log): if this process was itself not running for a while since
/// `since` (stopped with SIGSTOP, suspended, starved: see
/// [`crate::net::stall`]), the coordinator may have given the frame up
/// meanwhile, and its `Goodbye` (or the closed link) may still be on its
/// way through this process's reader while the peers' messages, buffered
/// before the stop, let the frame run to its end. Then wait up to
/// [`STALL_CHECK`] for it: the coordinator is essential here, so its
/// `Goodbye` is an error, and so is a lost link. Messages read meanwhile
/// are dropped (none is due at this point). A frame without a stall pays
/// nothing.
pub fn given_up_while_stopped<T: RemoteTransport>(t: &T, since: Instant) -> anyhow::Result<()> {
    let stalled = crate::net::stall::longest_since(since);
    if stalled.is_zero() {
        return Ok(());
    }
    let until = Instant::now() + STALL_CHECK;
    loop {
        let left = until.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Ok(());
        }
        match t.recv_timeout(left) {
            Ok(None) => return Ok(()),
            Ok(Some(_)) => {}
            Err(e) => anyhow::bail!(
                "this worker was not running for about {:.1} s, and the frame was given up meanwhile: {e}",
                stalled.as_secs_f64()
            ),
        }
    }
}

/// Ends a worker's failed frame (begun at `since`) with
/// [`RemoteTransport::close_after_failure`], and says so when it leaves
/// as a lost worker (it was not running for about its deadline: the
/// frame was given up because of it).
pub fn close_failed<T: RemoteTransport>(t: &T, since: Instant) {
    if t.close_after_failure(since, Duration::from_secs(2)) {
        crate::cluster::remote::hooks::say(&format!(
            "this worker was not running for about {:.1} s during the frame; \
             it leaves the frame as a lost worker (no Goodbye), so that it is the one dropped",
            crate::net::stall::longest_since(since).as_secs_f64()
        ));
    }
}

/// A worker's failure report to the coordinator `coord` (its frame began
/// at `since`): `Lost` with the peers whose links it lost
/// ([`RemoteTransport::lost_peers`]; the coordinator excepted), if any,
/// then `Failed(why)`. Send errors are ignored: the links may be gone.
pub fn report_failure<T: RemoteTransport>(
    t: &T,
    coord: NodeId,
    codec: &Codec,
    why: &str,
    since: Instant,
) {
    let lost: Vec<u32> = t
        .lost_peers(since)
        .into_iter()
        .filter(|&r| r != coord)
        .map(|r| r.0)
        .collect();
    if !lost.is_empty() {
        if let Ok(b) = codec.encode(&Session::Lost(lost)) {
            let _ = t.send(coord, MessageKind::Session, b);
        }
    }
    if let Ok(b) = codec.encode(&Session::Failed(why.to_string())) {
        let _ = t.send(coord, MessageKind::Session, b);
    }
}

/// The coordinator's side of a worker's `Lost(ranks)` report (from
/// `from`): each reported worker (a rank of `t` other than `from` and
/// the coordinator itself) counts as lost ([`RemoteTransport::blame`]).
/// Returns the names of the blamed workers and the reason, for the
/// frame's error (the report ends the frame; the `Failed` that follows
/// it says why `from` gave up).
pub fn take_blame<T: RemoteTransport>(t: &T, from: NodeId, ranks: &[u32]) -> (String, String) {
    let mut names = Vec::new();
    // Only the coordinator (the last rank) takes a report: a worker that
    // is sent one blames no one.
    let coordinator = t.rank().index() + 1 == t.size();
    for &r in ranks.iter().filter(|_| coordinator) {
        let r = NodeId(r);
        if r != from && r != t.rank() && r.index() < t.size() {
            t.blame(r);
            names.push(t.peer_name(r));
        }
    }
    let from = t.peer_name(from);
    if names.is_empty() {
        return (
            from,
            "sent a report of lost peers that names none of them".into(),
        );
    }
    (
        names.join(", "),
        format!(
            "lost by {from}: its link ended without Goodbye (closed, or silent past that worker's deadline)"
        ),
    )
}
