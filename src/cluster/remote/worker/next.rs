//! Between two frames of a session, on a worker: the links, the cells or
//! pieces and the peers stay; the coordinator's next `Setup` arrives over
//! the same links ([`next_frame`]), or its `End`. Before the new frame's
//! `Need`, each worker sends every peer a `Flush` and reads up to every
//! peer's `Flush` ([`flush`]): links are FIFO, so what a peer sent before
//! its flush (a late message of the last frame) is dropped, and nothing of
//! the last frame reaches the next one.

use std::time::Duration;

use crate::cluster::remote::session::{Session, WorkerSetup};
use crate::net::{Codec, MessageKind, NodeId, RemoteTransport};

/// How long a session may stay idle between frames: as long as its links
/// live (heartbeats flow; a lost coordinator ends the wait at once).
const IDLE_POLL: Duration = Duration::from_secs(3600);

/// What the coordinator said between frames.
pub enum Next {
    /// The next frame's set-up (the peers' flushes are in).
    Frame(Box<WorkerSetup>),
    /// The session is over.
    End,
}

/// Waits for the coordinator's next frame (`setup` is the last one's: the
/// next keeps its rank, node count and peers) or the end of the session.
/// Peers' flushes that come first are counted; then [`flush`] reads the
/// rest within `wait`.
pub fn next_frame<T: RemoteTransport>(
    t: &T,
    setup: &WorkerSetup,
    codec: Codec,
    wait: Duration,
) -> anyhow::Result<Next> {
    let coord = NodeId(setup.nodes);
    let me = setup.rank as usize;
    let mut flushed = vec![false; setup.nodes as usize];
    flushed[me] = true;
    t.set_essential(coord, true);
    loop {
        let Some(e) = t.recv_timeout(IDLE_POLL)? else {
            continue;
        };
        if e.kind != MessageKind::Session {
            // A late message of the last frame.
            continue;
        }
        match codec.decode::<Session>(&e.payload) {
            Ok(Session::End) if e.from == coord => return Ok(Next::End),
            Ok(Session::Setup(next)) if e.from == coord => {
                same_session(setup, &next)?;
                flush(t, me, &mut flushed, codec, wait)?;
                return Ok(Next::Frame(next));
            }
            other => take_flush(t, &e, other, &mut flushed)?,
        }
    }
}

/// A peer's session message between frames: its `Flush` is counted in
/// `flushed`; its failure, or anything else, is an error.
fn take_flush<T: RemoteTransport>(
    t: &T,
    e: &crate::net::Envelope,
    msg: crate::net::NetResult<Session>,
    flushed: &mut [bool],
) -> anyhow::Result<()> {
    match msg {
        Ok(Session::Flush) if e.from.index() < flushed.len() => {
            flushed[e.from.index()] = true;
            Ok(())
        }
        Ok(Session::Failed(why)) => anyhow::bail!("{} failed: {why}", t.peer_name(e.from)),
        _ => anyhow::bail!(
            "{} sent a session message out of turn between frames",
            t.peer_name(e.from)
        ),
    }
}

/// The next set-up must keep the session's shape: the links are its.
fn same_session(last: &WorkerSetup, next: &WorkerSetup) -> anyhow::Result<()> {
    next.validate()
        .map_err(|e| anyhow::anyhow!("bad set-up from the coordinator: {e}"))?;
    anyhow::ensure!(
        next.rank == last.rank && next.nodes == last.nodes && next.peers == last.peers,
        "the coordinator's next set-up is for node {} of {} (this session: node {} of {}, \
         the same peers)",
        next.rank,
        next.nodes,
        last.rank,
        last.nodes
    );
    Ok(())
}

/// Sends `Flush` to every peer, then reads until every peer's flush is in
/// (`flushed[k]`; this rank's own entry is set), dropping what came before
/// them. At most `wait`.
pub fn flush<T: RemoteTransport>(
    t: &T,
    me: usize,
    flushed: &mut [bool],
    codec: Codec,
    wait: Duration,
) -> anyhow::Result<()> {
    let msg = codec.encode(&Session::Flush)?;
    for k in (0..flushed.len()).filter(|&k| k != me) {
        t.send(NodeId::from(k), MessageKind::Session, msg.clone())?;
    }
    let until = std::time::Instant::now() + wait;
    while flushed.iter().any(|f| !f) {
        let left = until.saturating_duration_since(std::time::Instant::now());
        let e = t.recv_timeout(left)?.ok_or_else(|| {
            let missing: Vec<String> = (0..flushed.len())
                .filter(|&k| !flushed[k])
                .map(|k| t.peer_name(NodeId::from(k)))
                .collect();
            anyhow::anyhow!(
                "between frames: no flush from {} within {wait:?} (stalled or lost)",
                missing.join(", ")
            )
        })?;
        if e.kind != MessageKind::Session {
            continue;
        }
        take_flush(t, &e, codec.decode::<Session>(&e.payload), flushed)?;
    }
    Ok(())
}

/// The coordinator's `Cells` for a frame whose set-up names `sha` (after
/// this worker's `Need(true)`), checked against it; at most `wait`.
pub fn recv_cells<T: RemoteTransport>(
    t: &T,
    coord: NodeId,
    sha: &[u8; 32],
    codec: Codec,
    wait: Duration,
) -> anyhow::Result<Vec<u8>> {
    let e = t
        .recv_timeout(wait)?
        .ok_or_else(|| anyhow::anyhow!("no cells from the coordinator within {wait:?}"))?;
    let m: Session = codec.decode(&e.payload)?;
    let Session::Cells(bytes) = m else {
        anyhow::bail!("the coordinator sent {m:?} instead of the cells");
    };
    anyhow::ensure!(
        e.from == coord && crate::cluster::remote::session::sha256(&bytes) == *sha,
        "the cells from the coordinator do not match their SHA-256"
    );
    Ok(bytes)
}
