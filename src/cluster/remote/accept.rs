//! The worker's door: one task accepts every connection and runs each
//! handshake concurrently, so silent or slow connections never keep a
//! legitimate coordinator out.
//!
//! - At most [`MAX_PENDING`] connections may be unauthenticated at once; a
//!   new one beyond that evicts the oldest pending one (an attacker must
//!   out-pace real handshakes, which take milliseconds, not merely hold
//!   sockets open).
//! - Each must finish its handshake within [`PRE_AUTH`] (or the link's
//!   handshake timeout, if shorter).
//! - Nothing but a fixed refusal goes to an unauthenticated peer (see
//!   [`crate::net::tcp::handshake`]); the reason is logged here.
//! - Authenticated coordinators and probes start a session if the worker
//!   is idle or becomes idle within [`BUSY_GRACE`] (the tail of the last
//!   session: a coordinator that starts its next frame at once must not
//!   race the worker closing the previous one); while it stays busy, a
//!   coordinator is told so (`Session::Failed("busy ...")`) and a probe
//!   is closed. Authenticated
//!   workers (mesh peers) wait in a bounded queue for the session's mesh
//!   (a peer may dial before this worker's own set-up arrives); stale ones
//!   are dropped.

use std::collections::VecDeque;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::runtime::Runtime;
use tokio::sync::mpsc;
use tokio::task::AbortHandle;

use crate::cluster::remote::session::Session;
use crate::net::tcp::handshake::{listen, PeerHello, Role};
use crate::net::tcp::{TcpOptions, Token};
use crate::net::{Codec, NodeId};

/// Most connections that may be in their handshake at once.
pub const MAX_PENDING: usize = 128;
/// Longest a connection may take to authenticate.
pub const PRE_AUTH: Duration = Duration::from_secs(3);
/// How long a coordinator or probe that arrives while a session runs
/// waits for it to end before it is told "busy": a session's tail (links
/// closing after the result went out) takes milliseconds, and the next
/// frame of a series arrives in it. At most half the heartbeat deadline,
/// which the coordinator allows for the worker's answer.
pub const BUSY_GRACE: Duration = Duration::from_millis(1500);
/// Mesh peers that may wait for a session to take them (beyond that, the
/// oldest is dropped).
const PEER_QUEUE: usize = 256;
/// A waiting mesh peer older than this is stale (a mesh forms within the
/// mesh's own limit, a few handshake timeouts).
const PEER_MAX_AGE: Duration = Duration::from_secs(30);

/// An authenticated connection.
pub struct Accepted {
    /// The stream, after the handshake.
    pub stream: TcpStream,
    /// What the peer said it is.
    pub hello: PeerHello,
    /// Its address.
    pub from: SocketAddr,
}

struct Shared {
    /// A session (coordinator or probe) holds the worker.
    busy: AtomicBool,
    /// The rank this worker states in its handshakes (its node's rank in a
    /// session, `u32::MAX` between sessions).
    rank: AtomicU32,
    token: Token,
    opts: TcpOptions,
    pending: Mutex<VecDeque<(u64, AbortHandle)>>,
    next_id: AtomicU64,
    sessions: mpsc::Sender<Accepted>,
    /// Authenticated workers, oldest first, for the session's mesh (a
    /// peer may dial before this worker's own set-up has arrived).
    peers: Mutex<VecDeque<(Instant, Accepted)>>,
    peer_ready: tokio::sync::Notify,
}

/// The accepting task and what it hands over.
pub struct Door {
    shared: Arc<Shared>,
    sessions: tokio::sync::Mutex<mpsc::Receiver<Accepted>>,
    local: SocketAddr,
    task: AbortHandle,
}

impl Drop for Door {
    fn drop(&mut self) {
        self.task.abort();
        let pending = std::mem::take(&mut *lock(&self.shared.pending));
        for (_, h) in pending {
            h.abort();
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl Door {
    /// Starts accepting on `listener` (on `rt`).
    pub fn open(rt: &Runtime, listener: TcpListener, token: Token, opts: TcpOptions) -> Door {
        let local = listener
            .local_addr()
            .unwrap_or_else(|_| SocketAddr::from(([127, 0, 0, 1], 0)));
        let (stx, srx) = mpsc::channel(1);
        let shared = Arc::new(Shared {
            busy: AtomicBool::new(false),
            rank: AtomicU32::new(u32::MAX),
            token,
            opts,
            pending: Mutex::new(VecDeque::new()),
            next_id: AtomicU64::new(0),
            sessions: stx,
            peers: Mutex::new(VecDeque::new()),
            peer_ready: tokio::sync::Notify::new(),
        });
        let sh = Arc::clone(&shared);
        let task = rt.spawn(accept_loop(listener, sh)).abort_handle();
        Door {
            shared,
            sessions: tokio::sync::Mutex::new(srx),
            local,
            task,
        }
    }

    /// The address it listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.local
    }

    /// The next session's connection (a coordinator or a probe); the worker
    /// is busy from then until [`Door::session_done`].
    pub async fn next_session(&self) -> Option<Accepted> {
        self.sessions.lock().await.recv().await
    }

    /// The next mesh peer's connection (an authenticated worker).
    pub async fn next_peer(&self) -> Option<Accepted> {
        loop {
            {
                let mut q = lock(&self.shared.peers);
                while let Some((t, a)) = q.pop_front() {
                    if t.elapsed() < PEER_MAX_AGE {
                        return Some(a);
                    }
                }
            }
            self.shared.peer_ready.notified().await;
        }
    }

    /// The rank to state in handshakes during the session.
    pub fn set_rank(&self, rank: u32) {
        self.shared.rank.store(rank, Ordering::SeqCst);
        crate::cluster::remote::hooks::set_rank(rank);
    }

    /// The session is over: accept the next one.
    pub fn session_done(&self) {
        self.shared.rank.store(u32::MAX, Ordering::SeqCst);
        self.shared.busy.store(false, Ordering::SeqCst);
    }
}

async fn accept_loop(listener: TcpListener, sh: Arc<Shared>) {
    loop {
        let (s, from) = match listener.accept().await {
            Ok(x) => x,
            Err(e) => {
                // Out of file descriptors and the like: wait, then retry.
                crate::cluster::remote::hooks::say(&format!("accepting a connection: {e}"));
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
        };
        let _ = s.set_nodelay(true);
        let id = sh.next_id.fetch_add(1, Ordering::Relaxed);
        let evicted = {
            let mut p = lock(&sh.pending);
            let mut ev = None;
            if p.len() >= MAX_PENDING {
                ev = p.pop_front();
            }
            let task = tokio::spawn(handshake(s, from, id, Arc::clone(&sh)));
            p.push_back((id, task.abort_handle()));
            ev
        };
        if let Some((_, h)) = evicted {
            h.abort();
            crate::cluster::remote::hooks::say(&format!(
                "{MAX_PENDING} connections were waiting to authenticate; closed the oldest"
            ));
        }
    }
}

/// Sets `busy` if it is clear now or clears within `grace` (checked every
/// 10 ms); false if it stayed set.
async fn take_within(busy: &AtomicBool, grace: Duration) -> bool {
    let until = Instant::now() + grace;
    loop {
        let took = busy
            .compare_exchange(false, true, Ordering::SeqCst, Ordering::SeqCst)
            .is_ok();
        if took || Instant::now() >= until {
            return took;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

async fn handshake(mut s: TcpStream, from: SocketAddr, id: u64, sh: Arc<Shared>) {
    let t = sh.opts.handshake_timeout.min(PRE_AUTH);
    let name = from.to_string();
    let rank = sh.rank.load(Ordering::SeqCst);
    let r = tokio::time::timeout(t, listen(&mut s, &sh.token, Role::Worker, rank, &name)).await;
    lock(&sh.pending).retain(|(i, _)| *i != id);
    let hello = match r {
        Ok(Ok(h)) => h,
        Ok(Err(e)) => {
            crate::cluster::remote::hooks::say(&format!("refused a connection: {e}"));
            return;
        }
        Err(_) => {
            crate::cluster::remote::hooks::say(&format!(
                "refused a connection from {from}: no complete handshake within {:.1} s",
                t.as_secs_f64()
            ));
            return;
        }
    };
    let a = Accepted {
        stream: s,
        hello,
        from,
    };
    match hello.role {
        Role::Coordinator | Role::Probe => {
            if take_within(&sh.busy, BUSY_GRACE.min(sh.opts.deadline / 2)).await {
                if sh.sessions.send(a).await.is_err() {
                    sh.busy.store(false, Ordering::SeqCst);
                }
            } else {
                crate::cluster::remote::hooks::say(&format!(
                    "{:?} {from} connected while a session runs; told it is busy",
                    hello.role
                ));
                if hello.role == Role::Coordinator {
                    busy(a, &sh.opts).await;
                }
            }
        }
        Role::Worker => {
            let dropped = {
                let mut q = lock(&sh.peers);
                q.retain(|(t, _)| t.elapsed() < PEER_MAX_AGE);
                let d = if q.len() >= PEER_QUEUE {
                    q.pop_front()
                } else {
                    None
                };
                q.push_back((Instant::now(), a));
                d
            };
            sh.peer_ready.notify_one();
            if let Some((_, d)) = dropped {
                crate::cluster::remote::hooks::say(&format!(
                    "{PEER_QUEUE} peers were waiting for a session; closed the oldest ({})",
                    d.from
                ));
            }
        }
    }
}

/// Tells an authenticated coordinator this worker is busy: a `Failed`
/// message in place of its cache answer; then reads what it sent (its
/// set-up) for a moment so that closing does not reset the connection
/// before it reads the answer.
async fn busy(mut a: Accepted, opts: &TcpOptions) {
    let codec = Codec::default();
    let msg = Session::Failed(
        "busy: this worker is serving another session; try again when it is done".into(),
    );
    let name = a.from.to_string();
    let to = NodeId(a.hello.rank);
    let send = crate::net::tcp::raw::write_msg(&mut a.stream, &codec, NodeId(0), to, &msg, &name);
    if tokio::time::timeout(opts.handshake_timeout, send)
        .await
        .is_err()
    {
        return;
    }
    let _ = a.stream.shutdown().await;
    let drain = async {
        let mut buf = vec![0u8; 64 * 1024];
        let mut total = 0usize;
        while let Ok(n) = a.stream.read(&mut buf).await {
            total += n;
            if n == 0 || total > (64 << 20) {
                break;
            }
        }
    };
    let _ = tokio::time::timeout(Duration::from_secs(2), drain).await;
}
