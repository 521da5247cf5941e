//! [`TcpTransport`]: one rank's endpoint over authenticated TCP links, one
//! link per peer rank (a full mesh).
//!
//! ```text
//!  actor thread ── send ──► mpsc ──► writer task ──► socket   (heartbeat when idle,
//!                                                             Goodbye when dropped)
//!  actor thread ◄── recv ── crossbeam inbox ◄── reader task ◄── socket
//!                                               (deadline: no frame for `deadline` = lost)
//! ```
//!
//! All tasks run on one tokio runtime shared by the process. The actor side
//! stays synchronous: it implements [`Transport`], so node and manager code
//! never learn they are on TCP. A reader that sees EOF without `Goodbye`,
//! an I/O error, a malformed or oversized frame, a frame whose header names
//! another sender or receiver than the link's, or silence past the
//! deadline puts a `Lost` event into the inbox; the next `recv` returns it
//! as [`NetError::PeerLost`] naming the peer. A `Goodbye` is a clean end;
//! it is an error only from a peer marked *essential* (one the caller still
//! needs: the coordinator for a worker, a worker whose results are not in),
//! or after this process was itself not running long enough for its
//! peers' deadlines to pass (they gave the frame up because of it).
//!
//! Counting: payload bytes per kind and destination in the same
//! [`crate::net::TrafficStats`] the simulator fills, plus the bytes really written and
//! read (frames, heartbeats, goodbyes) in [`WireStats`].

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};
use tokio::io::AsyncWriteExt;
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};
use tokio::net::TcpStream;
use tokio::runtime::Runtime;
use tokio::sync::mpsc;
use tokio::task::JoinHandle;

use super::frame::{data_frame_bytes, encode_frame, read_frame_async, LinkFrame, TAG_HEARTBEAT};
use crate::net::error::{NetError, NetResult};
use crate::net::inbox::{self, lock, Inbox, Wait};
use crate::net::message::{Codec, Envelope, MessageKind, NodeId};
use crate::net::remote::{RemoteTransport, WireStats};
use crate::net::transport::{check_rank, Transport};

/// Timing and size knobs of TCP links.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcpOptions {
    /// Payload limit of a frame after authentication.
    pub codec: Codec,
    /// A link idle this long sends a heartbeat.
    pub heartbeat: Duration,
    /// A link silent this long (no frame, no heartbeat; or no progress
    /// inside a frame) is declared lost: the peer stalled or died.
    pub deadline: Duration,
    /// Longest connect + handshake.
    pub handshake_timeout: Duration,
}

impl Default for TcpOptions {
    /// Heartbeat every 200 ms, lost after 3 s of silence, 5 s to connect.
    fn default() -> Self {
        TcpOptions {
            codec: Codec::default(),
            heartbeat: Duration::from_millis(200),
            deadline: Duration::from_secs(3),
            handshake_timeout: Duration::from_secs(5),
        }
    }
}

/// An authenticated connection to the peer of rank `rank`.
#[derive(Debug)]
pub struct Link {
    /// The peer's rank.
    pub rank: NodeId,
    /// The peer's name for errors, e.g. `worker 2 (127.0.0.1:4711)`.
    pub name: String,
    /// The socket (handshake done, `TCP_NODELAY` set).
    pub stream: TcpStream,
}

pub(crate) enum Incoming {
    Msg(Envelope),
    Goodbye(NodeId),
    Lost(NodeId, String),
}

struct Peer {
    tx: Option<mpsc::UnboundedSender<Vec<u8>>>,
    name: String,
    said_goodbye: bool,
    lost: bool,
    essential: bool,
}

/// One rank's endpoint on a TCP mesh. See the module docs.
pub struct TcpTransport {
    rank: NodeId,
    size: usize,
    rt: Arc<Runtime>,
    peers: Mutex<Vec<Option<Peer>>>,
    self_tx: Sender<Incoming>,
    inbox: Receiver<Incoming>,
    codec: Codec,
    stats: Arc<Mutex<WireStats>>,
    failed: Mutex<Option<(String, String)>>,
    deadline: Duration,
    heartbeat: Duration,
    created: Instant,
    writers: Mutex<Vec<JoinHandle<()>>>,
    readers: Mutex<Vec<JoinHandle<()>>>,
}

impl TcpTransport {
    /// An endpoint of rank `rank` in a network of `size` ranks over
    /// `links` (at most one per other rank; ranks without a link cannot be
    /// reached). Spawns a reader and a writer task per link on `rt`.
    pub fn new(
        rt: Arc<Runtime>,
        rank: NodeId,
        size: usize,
        links: Vec<Link>,
        opts: TcpOptions,
    ) -> NetResult<TcpTransport> {
        let (self_tx, inbox) = crossbeam_channel::unbounded();
        let stats = Arc::new(Mutex::new(WireStats::default()));
        let mut peers: Vec<Option<Peer>> = (0..size).map(|_| None).collect();
        let mut writers = Vec::new();
        let mut readers = Vec::new();
        for l in links {
            check_rank(l.rank, size)?;
            if l.rank == rank || peers[l.rank.index()].is_some() {
                return Err(NetError::Sim(format!(
                    "{}: a second link for {} (or a link to itself)",
                    l.name, l.rank
                )));
            }
            let (r, w) = l.stream.into_split();
            let (tx, rx) = mpsc::unbounded_channel();
            writers.push(rt.spawn(writer(w, rx, opts.heartbeat, Arc::clone(&stats))));
            readers.push(rt.spawn(reader(
                r,
                l.rank,
                rank,
                opts,
                self_tx.clone(),
                Arc::clone(&stats),
            )));
            peers[l.rank.index()] = Some(Peer {
                tx: Some(tx),
                name: l.name,
                said_goodbye: false,
                lost: false,
                essential: false,
            });
        }
        Ok(TcpTransport {
            rank,
            size,
            rt,
            peers: Mutex::new(peers),
            self_tx,
            inbox,
            codec: opts.codec,
            stats,
            failed: Mutex::new(None),
            deadline: opts.deadline,
            heartbeat: opts.heartbeat,
            created: Instant::now(),
            writers: Mutex::new(writers),
            readers: Mutex::new(readers),
        })
    }

    /// How long this process was not running since `since` (see
    /// [`crate::net::stall`]), if that was long enough for a peer to hear
    /// nothing from it for a whole deadline (the stall, plus up to one
    /// heartbeat period before it, plus the watchdog's resolution): its
    /// peers may have declared it lost. A shorter stall cannot have made
    /// any peer's deadline pass.
    fn stalled_out(&self, since: Instant) -> Option<Duration> {
        let s = crate::net::stall::longest_since(since);
        (!s.is_zero() && s + self.heartbeat + crate::net::stall::TICK >= self.deadline).then_some(s)
    }

    fn fail(&self, peer: NodeId, reason: String) -> NetError {
        if let Some(Some(p)) = lock(&self.peers).get_mut(peer.index()) {
            // An essential peer's Goodbye is an error, not a loss.
            p.lost |= !p.said_goodbye;
        }
        let name = self.peer_name(peer);
        let mut f = lock(&self.failed);
        if f.is_none() {
            *f = Some((name.clone(), reason.clone()));
        }
        NetError::PeerLost { peer: name, reason }
    }

    /// Turns an inbox item into a message, `None` (a benign goodbye), or
    /// the error it stands for.
    fn take(&self, item: Incoming) -> NetResult<Option<Envelope>> {
        match item {
            Incoming::Msg(e) => {
                let mut s = lock(&self.stats);
                s.payload.record_recv(e.kind, e.len());
                s.wire_bytes_recv += data_frame_bytes(e.len());
                Ok(Some(e))
            }
            Incoming::Goodbye(r) => {
                let essential = {
                    let mut peers = lock(&self.peers);
                    match peers.get_mut(r.index()) {
                        Some(Some(p)) => {
                            p.said_goodbye = true;
                            p.essential
                        }
                        _ => false,
                    }
                };
                if essential {
                    Err(self.fail(
                        r,
                        "closed the connection (Goodbye) before it was done".into(),
                    ))
                } else if let Some(s) = self.stalled_out(self.created) {
                    // It may well have given up on us: so does this rank.
                    Err(self.fail(
                        r,
                        format!(
                            "closed the connection (Goodbye) after this process was not running \
                             for about {:.1} s (stopped, e.g. SIGSTOP, or starved): the frame was \
                             given up because of it",
                            s.as_secs_f64()
                        ),
                    ))
                } else {
                    Ok(None)
                }
            }
            Incoming::Lost(r, why) => Err(self.fail(r, why)),
        }
    }
}

impl RemoteTransport for TcpTransport {
    /// Marks a peer as needed: its `Goodbye` is then an error (it left
    /// before it was done), not a clean end.
    fn set_essential(&self, rank: NodeId, essential: bool) {
        if let Some(Some(p)) = lock(&self.peers).get_mut(rank.index()) {
            p.essential = essential;
        }
    }

    /// The name of a peer (for error messages).
    fn peer_name(&self, rank: NodeId) -> String {
        match lock(&self.peers).get(rank.index()) {
            Some(Some(p)) => p.name.clone(),
            _ => rank.to_string(),
        }
    }

    /// Counts so far.
    fn stats(&self) -> WireStats {
        lock(&self.stats).clone()
    }

    /// Sends `Goodbye` on every link, waits (at most `wait`) for the
    /// writers to flush, then stops the readers and any writer that could
    /// not flush (the link is closed). Also done on drop.
    fn close(&self, wait: Duration) {
        for p in lock(&self.peers).iter_mut().flatten() {
            p.tx = None;
        }
        let writers: Vec<_> = lock(&self.writers).drain(..).collect();
        let readers: Vec<_> = lock(&self.readers).drain(..).collect();
        if writers.is_empty() && readers.is_empty() {
            return;
        }
        let mut writers = writers;
        self.rt.block_on(async {
            let _ = tokio::time::timeout(wait, async {
                for h in &mut writers {
                    let _ = h.await;
                }
            })
            .await;
        });
        // A writer still blocked (its peer stopped reading: a full socket
        // buffer) is ended too, or it would hold the link, its socket and
        // its queued frames for as long as the process lives.
        for h in writers.iter().chain(&readers) {
            h.abort();
        }
    }

    /// See [`RemoteTransport::close_after_failure`]: "a while" is long
    /// enough for a peer's deadline to pass (`stalled_out`). Each writer
    /// gets an empty frame (never a real one), its signal to shut the
    /// socket down without `Goodbye`.
    fn close_after_failure(&self, since: Instant, wait: Duration) -> bool {
        let lost = self.stalled_out(since).is_some();
        if lost {
            for p in lock(&self.peers).iter_mut().flatten() {
                if let Some(tx) = p.tx.take() {
                    let _ = tx.send(Vec::new());
                }
            }
        }
        self.close(wait);
        lost
    }

    /// See [`RemoteTransport::lost_peers`]: the links marked lost, unless
    /// this process stalled out since `since`.
    fn lost_peers(&self, since: Instant) -> Vec<NodeId> {
        if self.stalled_out(since).is_some() {
            return Vec::new();
        }
        lock(&self.peers)
            .iter()
            .enumerate()
            .filter(|(_, p)| p.as_ref().is_some_and(|p| p.lost))
            .map(|(k, _)| NodeId::from(k))
            .collect()
    }

    /// See [`RemoteTransport::blame`]: the link is marked lost and its
    /// writer gets the empty frame that shuts the socket down without
    /// `Goodbye`.
    fn blame(&self, rank: NodeId) {
        if let Some(Some(p)) = lock(&self.peers).get_mut(rank.index()) {
            p.lost = true;
            if let Some(tx) = p.tx.take() {
                let _ = tx.send(Vec::new());
            }
        }
    }

    /// How each rank's link ended, after waiting at most `wait` for the
    /// links still open to end (messages read meanwhile are dropped):
    /// `Some(true)` a clean `Goodbye`, `Some(false)` lost (closed without
    /// `Goodbye`, an I/O or frame error, silence past the deadline), `None`
    /// still open (or no link: this rank, or a rank never linked). For a
    /// caller whose frame failed: which peers died, and which only gave up.
    fn link_endings(&self, wait: Duration) -> Vec<Option<bool>> {
        let until = std::time::Instant::now() + wait;
        let endings = |peers: &[Option<Peer>]| -> Vec<Option<bool>> {
            peers
                .iter()
                .map(|p| match p {
                    Some(p) if p.lost => Some(false),
                    Some(p) if p.said_goodbye => Some(true),
                    _ => None,
                })
                .collect()
        };
        loop {
            let open = lock(&self.peers)
                .iter()
                .any(|p| p.as_ref().is_some_and(|p| !p.lost && !p.said_goodbye));
            let left = until.saturating_duration_since(std::time::Instant::now());
            if !open || left.is_zero() {
                return endings(&lock(&self.peers));
            }
            let item = match self.inbox.recv_timeout(left) {
                Ok(i) => i,
                Err(_) => return endings(&lock(&self.peers)),
            };
            let mut peers = lock(&self.peers);
            match item {
                Incoming::Msg(_) => {}
                Incoming::Goodbye(r) => {
                    if let Some(Some(p)) = peers.get_mut(r.index()) {
                        p.said_goodbye = true;
                    }
                }
                Incoming::Lost(r, _) => {
                    if let Some(Some(p)) = peers.get_mut(r.index()) {
                        p.lost = true;
                    }
                }
            }
        }
    }
}

impl Drop for TcpTransport {
    fn drop(&mut self) {
        self.close(Duration::from_secs(2));
    }
}

impl Transport for TcpTransport {
    fn rank(&self) -> NodeId {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn send(&self, to: NodeId, kind: MessageKind, payload: Vec<u8>) -> NetResult<()> {
        // No global failure check here: after losing one peer a rank must
        // still be able to tell the others why.
        check_rank(to, self.size)?;
        let n = payload.len() as u64;
        let env = Envelope {
            from: self.rank,
            to,
            kind,
            payload,
        };
        if to == self.rank {
            lock(&self.stats).payload.record_send(to, kind, n);
            return self
                .self_tx
                .send(Incoming::Msg(env))
                .map_err(|_| NetError::Disconnected { rank: self.rank });
        }
        let frame = encode_frame(&self.codec, &LinkFrame::Data(env))?;
        let peers = lock(&self.peers);
        let p = match peers.get(to.index()) {
            Some(Some(p)) => p,
            _ => {
                return Err(NetError::Sim(format!(
                    "{}: no link to {to} (not part of this mesh)",
                    self.rank
                )))
            }
        };
        if p.said_goodbye {
            // Like a message to a stopped actor: dropped.
            return Ok(());
        }
        let sent = p.tx.as_ref().is_some_and(|tx| tx.send(frame).is_ok());
        if !sent {
            let name = p.name.clone();
            drop(peers);
            return Err(self.fail(
                to,
                format!("cannot send a {kind} message to {name}: the connection is gone"),
            ));
        }
        drop(peers);
        let mut s = lock(&self.stats);
        s.payload.record_send(to, kind, n);
        s.wire_bytes_sent += data_frame_bytes(n);
        Ok(())
    }

    fn recv(&self) -> NetResult<Envelope> {
        inbox::receive_blocking(self)
    }

    fn recv_timeout(&self, timeout: Duration) -> NetResult<Option<Envelope>> {
        inbox::receive(self, Wait::Until(Instant::now() + timeout))
    }

    fn try_recv(&self) -> NetResult<Option<Envelope>> {
        inbox::receive(self, Wait::Poll)
    }
}

async fn writer(
    mut w: OwnedWriteHalf,
    mut rx: mpsc::UnboundedReceiver<Vec<u8>>,
    heartbeat: Duration,
    stats: Arc<Mutex<WireStats>>,
) {
    loop {
        match tokio::time::timeout(heartbeat, rx.recv()).await {
            Ok(Some(frame)) if frame.is_empty() => {
                // Ended as a lost rank: no Goodbye (see close_after_failure).
                let _ = w.shutdown().await;
                return;
            }
            Ok(Some(frame)) => {
                if w.write_all(&frame).await.is_err() {
                    return;
                }
            }
            Ok(None) => {
                if w.write_all(&[super::frame::TAG_GOODBYE]).await.is_ok() {
                    lock(&stats).wire_bytes_sent += 1;
                }
                let _ = w.shutdown().await;
                return;
            }
            Err(_) => {
                if w.write_all(&[TAG_HEARTBEAT]).await.is_err() {
                    return;
                }
                let mut s = lock(&stats);
                s.heartbeats_sent += 1;
                s.wire_bytes_sent += 1;
            }
        }
    }
}

async fn reader(
    mut r: OwnedReadHalf,
    peer: NodeId,
    me: NodeId,
    opts: TcpOptions,
    tx: Sender<Incoming>,
    stats: Arc<Mutex<WireStats>>,
) {
    let lost = |why: String| Incoming::Lost(peer, why);
    loop {
        match read_frame_async(&mut r, &opts.codec, Some(opts.deadline)).await {
            Ok(Some(LinkFrame::Data(env))) => {
                if env.from != peer || env.to != me {
                    let _ = tx.send(lost(format!(
                        "sent a frame from {} to {} on the link from {peer} to {me} (forged header)",
                        env.from, env.to
                    )));
                    return;
                }
                if tx.send(Incoming::Msg(env)).is_err() {
                    return;
                }
            }
            Ok(Some(LinkFrame::Heartbeat)) => {
                let mut s = lock(&stats);
                s.heartbeats_recv += 1;
                s.wire_bytes_recv += 1;
            }
            Ok(Some(LinkFrame::Goodbye)) => {
                lock(&stats).wire_bytes_recv += 1;
                let _ = tx.send(Incoming::Goodbye(peer));
                return;
            }
            Ok(None) => {
                let _ = tx.send(lost(
                    "closed the connection without Goodbye (the process died or was killed)".into(),
                ));
                return;
            }
            Err(e) => {
                let _ = tx.send(lost(e.to_string()));
                return;
            }
        }
    }
}

impl Inbox for TcpTransport {
    type Item = Incoming;
    fn me(&self) -> NodeId {
        self.rank
    }
    fn inbox(&self) -> NetResult<&Receiver<Incoming>> {
        Ok(&self.inbox)
    }
    fn failed(&self) -> &Mutex<Option<(String, String)>> {
        &self.failed
    }
    fn take(&self, item: Incoming) -> NetResult<Option<Envelope>> {
        TcpTransport::take(self, item)
    }
}
