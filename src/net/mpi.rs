//! The MPI transport (cargo feature `mpi`): the same [`Transport`] and
//! [`RemoteTransport`] as TCP, over the MPI library `mpirun` starts the
//! processes with (rsmpi over Debian's OpenMPI).
//!
//! ```text
//!  actor thread ── send ──► crossbeam ──► MPI thread ── MPI_Isend (tag = kind) ──► rank r
//!  actor thread ◄── recv ── crossbeam ◄── MPI thread ◄── MPI_Improbe + MPI_Mrecv ◄── any rank
//! ```
//!
//! One thread per process makes every MPI call (`MPI_THREAD_FUNNELED`: it
//! initialises MPI, so it is MPI's main thread); the actor side stays
//! synchronous, as with TCP. Sends are non-blocking (`MPI_Isend` from a
//! buffer the thread owns until `MPI_Test` says it is done), so two ranks
//! sending to each other never deadlock, and the thread receives every
//! message as soon as it arrives, so a sender's rendezvous always
//! completes. When idle the thread polls with a back-off (20 µs doubling
//! to 1 ms) and wakes at once for a send.
//!
//! Ranks: MPI rank 0 is the coordinator, rank `k ≥ 1` is node `k - 1`; in
//! [`NodeId`]s the coordinator is node `N` (after the `N` nodes), as with
//! TCP, so the drivers see the same numbering.
//!
//! Framing: the message kind is the MPI tag, the payload is the message;
//! a zero-byte message of tag [`TAG_GOODBYE`] is the clean end. A message
//! longer than the codec's limit is checked from the probe's count, before
//! any buffer is allocated; it fails the link.
//!
//! Failure: MPI has no heartbeats here. A rank that dies makes `mpirun`
//! end the whole job (OpenMPI's default); a stalled rank is caught by the
//! drivers' receive deadlines (`--recv-timeout`), after which the rank
//! that noticed calls [`abort`] (`MPI_Abort`), which ends every rank.
//!
//! Counting: payload bytes per kind and destination, as the other
//! transports; [`WireStats::wire_bytes_sent`] counts the bytes handed to
//! MPI (payloads; goodbyes are zero bytes). MPI's own envelopes are not
//! visible to us.

use std::sync::{Mutex, OnceLock};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender, TryRecvError};
use mpi::point_to_point::{Destination, MatchedReceiveVec, Source};
use mpi::request::{Request, StaticScope};
use mpi::topology::Communicator;
use mpi::traits::Equivalence;

use super::error::{NetError, NetResult};
use super::inbox::{self, lock, Inbox, Wait};
use super::message::{Codec, Envelope, MessageKind, NodeId};
use super::remote::{RemoteTransport, WireStats};
use super::transport::{check_rank, Transport};

/// The MPI tag of a goodbye (data messages use their kind's code).
pub const TAG_GOODBYE: i32 = 100;

/// The longest idle poll of the MPI thread.
const MAX_IDLE: Duration = Duration::from_millis(1);

/// What the actor side asks of the MPI thread.
enum Command {
    Send {
        to: i32,
        tag: i32,
        bytes: Vec<u8>,
    },
    /// Goodbye to everyone; wait (at most the duration) for the sends to
    /// leave and every peer's goodbye; finalize; answer.
    Close(Duration, Sender<()>),
    Abort(i32),
}

/// What the MPI thread hands the actor side.
pub(crate) enum Incoming {
    Msg { from: i32, tag: i32, bytes: Vec<u8> },
    Goodbye(i32),
    Lost(i32, String),
}

/// The process's MPI thread (one per process: MPI starts once).
struct World {
    rank: i32,
    size: i32,
    cmd: Sender<Command>,
    inbox: Receiver<Incoming>,
    thread: Mutex<Option<JoinHandle<()>>>,
}

static WORLD: OnceLock<Result<World, String>> = OnceLock::new();

/// Starts MPI (once per process) on its own thread; returns this
/// process's MPI rank and the number of ranks. An error if MPI cannot
/// start (for example, a binary linked against another MPI than the
/// `mpirun` that started it).
pub fn init(max_message_bytes: u64) -> NetResult<(usize, usize)> {
    let w = WORLD.get_or_init(|| start(max_message_bytes));
    match w {
        Ok(w) => Ok((w.rank as usize, w.size as usize)),
        Err(e) => Err(NetError::Io {
            what: "starting MPI".into(),
            msg: e.clone(),
        }),
    }
}

/// `MPI_Abort` on the world: ends every rank of the job with `code`. Does
/// not return. Without a started MPI, or alone (not under `mpirun`), exits
/// the process with `code`.
pub fn abort(code: i32) -> ! {
    if let Some(Ok(w)) = WORLD.get() {
        if w.size > 1 && w.cmd.send(Command::Abort(code)).is_ok() {
            // The MPI thread ends the process; wait for it.
            loop {
                std::thread::sleep(Duration::from_secs(60));
            }
        }
    }
    std::process::exit(code)
}

fn start(max_message_bytes: u64) -> Result<World, String> {
    let (cmd_tx, cmd_rx) = crossbeam_channel::unbounded();
    let (in_tx, in_rx) = crossbeam_channel::unbounded();
    let (ready_tx, ready_rx) = crossbeam_channel::bounded(1);
    let thread = std::thread::Builder::new()
        .name("pvrsim-mpi".into())
        .spawn(move || {
            let Some((universe, _)) = mpi::initialize_with_threading(mpi::Threading::Funneled)
            else {
                let _ = ready_tx.send(Err("MPI was already initialised".to_string()));
                return;
            };
            let world = universe.world();
            let _ = ready_tx.send(Ok((world.rank(), world.size())));
            pump(&world, &cmd_rx, &in_tx, max_message_bytes);
            // Dropping the universe calls MPI_Finalize.
            drop(universe);
        })
        .map_err(|e| format!("cannot start the MPI thread: {e}"))?;
    let (rank, size) = ready_rx
        .recv()
        .map_err(|_| "the MPI thread ended while starting MPI".to_string())??;
    Ok(World {
        rank,
        size,
        cmd: cmd_tx,
        inbox: in_rx,
        thread: Mutex::new(Some(thread)),
    })
}

/// A send in flight: the request and the buffer it reads, which the MPI
/// thread owns until the request completes.
struct Pending {
    req: Request<'static, [u8], StaticScope>,
    buf: *mut [u8],
}

impl Pending {
    fn start(world: &mpi::topology::SimpleCommunicator, to: i32, tag: i32, bytes: Vec<u8>) -> Self {
        let buf: &'static mut [u8] = Box::leak(bytes.into_boxed_slice());
        let ptr: *mut [u8] = buf;
        // SAFETY: `ptr` comes from `Box::leak` just above and is only
        // turned back into a box by `finish`, after MPI is done with it.
        let shared: &'static [u8] = unsafe { &*ptr };
        let req = world
            .process_at_rank(to)
            .immediate_send_with_tag(StaticScope, shared, tag);
        Pending { req, buf: ptr }
    }

    /// `Ok(())` once the send has completed (the buffer is freed).
    fn test(self) -> Result<(), Self> {
        match self.req.test() {
            Ok(_) => {
                // SAFETY: the request completed, so MPI no longer reads
                // the buffer; it was leaked from a box in `start`.
                drop(unsafe { Box::from_raw(self.buf) });
                Ok(())
            }
            Err(req) => Err(Pending { req, buf: self.buf }),
        }
    }
}

/// Tests every pending send; keeps those not done.
fn progress(pending: &mut Vec<Pending>) -> bool {
    let before = pending.len();
    let mut left = Vec::with_capacity(before);
    for p in pending.drain(..) {
        if let Err(p) = p.test() {
            left.push(p);
        }
    }
    *pending = left;
    pending.len() < before
}

/// Receives every message that has arrived. Returns whether any did, and
/// the ranks that said goodbye.
fn receive(
    world: &mpi::topology::SimpleCommunicator,
    tx: &Sender<Incoming>,
    limit: u64,
    goodbyes: &mut [bool],
    broken: &mut bool,
) -> bool {
    let mut any = false;
    while !*broken {
        let Some((msg, status)) = world.any_process().immediate_matched_probe() else {
            break;
        };
        any = true;
        let from = status.source_rank();
        let tag = status.tag();
        let count = status.count(u8::equivalent_datatype());
        if count < 0 || count as u64 > limit {
            // Not received: the run fails on this error (and aborts).
            std::mem::forget(msg);
            *broken = true;
            let _ = tx.send(Incoming::Lost(
                from,
                format!("sent a message of {count} bytes, over the {limit}-byte limit"),
            ));
            break;
        }
        let (bytes, _) = (msg, status).matched_receive_vec::<u8>();
        let item = if tag == TAG_GOODBYE {
            if let Some(g) = goodbyes.get_mut(from as usize) {
                *g = true;
            }
            Incoming::Goodbye(from)
        } else if (0..=255).contains(&tag) && MessageKind::from_code(tag as u8).is_some() {
            Incoming::Msg { from, tag, bytes }
        } else {
            Incoming::Lost(from, format!("sent a message of unknown tag {tag}"))
        };
        let _ = tx.send(item);
    }
    any
}

/// The state of the MPI thread between commands.
struct Pump<'w> {
    world: &'w mpi::topology::SimpleCommunicator,
    pending: Vec<Pending>,
    /// Set by `Close`: the deadline and whom to tell when done.
    close: Option<(Instant, Sender<()>)>,
}

impl Pump<'_> {
    fn goodbyes(&mut self, wait: Duration, done: Sender<()>) {
        if self.close.is_some() {
            return;
        }
        let me = self.world.rank();
        for r in (0..self.world.size()).filter(|&r| r != me) {
            self.pending
                .push(Pending::start(self.world, r, TAG_GOODBYE, Vec::new()));
        }
        self.close = Some((Instant::now() + wait, done));
    }

    fn apply(&mut self, c: Command) {
        match c {
            Command::Send { to, tag, bytes } => {
                // After Close, sends are dropped (the peers were told Goodbye).
                if self.close.is_none() {
                    self.pending
                        .push(Pending::start(self.world, to, tag, bytes));
                }
            }
            Command::Close(wait, done) => self.goodbyes(wait, done),
            Command::Abort(code) => self.world.abort(code),
        }
    }
}

/// The MPI thread's loop (see the module docs).
fn pump(
    world: &mpi::topology::SimpleCommunicator,
    cmd: &Receiver<Command>,
    tx: &Sender<Incoming>,
    limit: u64,
) {
    let mut p = Pump {
        world,
        pending: Vec::new(),
        close: None,
    };
    let mut goodbyes = vec![false; world.size() as usize];
    goodbyes[world.rank() as usize] = true;
    let mut broken = false;
    let mut idle = Duration::from_micros(20);
    loop {
        let mut busy = false;
        loop {
            match cmd.try_recv() {
                Ok(c) => {
                    p.apply(c);
                    busy = true;
                }
                Err(TryRecvError::Empty) => break,
                // Every handle is gone: end as if closed now.
                Err(TryRecvError::Disconnected) => {
                    let (d, _) = crossbeam_channel::bounded(1);
                    p.goodbyes(Duration::from_secs(10), d);
                    break;
                }
            }
        }
        busy |= progress(&mut p.pending);
        busy |= receive(world, tx, limit, &mut goodbyes, &mut broken);
        if let Some((until, _)) = &p.close {
            let done = p.pending.is_empty() && goodbyes.iter().all(|&g| g);
            if done || Instant::now() >= *until {
                // Sends still in flight past the deadline are left to MPI
                // (their requests never complete here: leak them).
                for q in p.pending.drain(..) {
                    std::mem::forget(q.req);
                }
                if let Some((_, d)) = p.close.take() {
                    let _ = d.send(());
                }
                return;
            }
        }
        if busy {
            idle = Duration::from_micros(20);
        } else {
            match cmd.recv_timeout(idle) {
                Ok(c) => {
                    p.apply(c);
                    idle = Duration::from_micros(20);
                }
                Err(_) => idle = (idle * 2).min(MAX_IDLE),
            }
        }
    }
}

struct Peer {
    said_goodbye: bool,
    essential: bool,
}

/// One rank's endpoint on the MPI job (see the module docs). Made once per
/// process by [`MpiTransport::new`] after [`init`].
pub struct MpiTransport {
    me: NodeId,
    nodes: usize,
    codec: Codec,
    peers: Mutex<Vec<Peer>>,
    stats: Mutex<WireStats>,
    failed: Mutex<Option<(String, String)>>,
    closed: Mutex<bool>,
}

impl MpiTransport {
    /// This process's endpoint for a frame of `nodes` nodes: MPI rank 0 is
    /// node `nodes` (the coordinator), MPI rank `k` node `k - 1`. Needs
    /// [`init`] first and exactly `nodes + 1` MPI ranks.
    pub fn new(nodes: usize, codec: Codec) -> NetResult<MpiTransport> {
        let (rank, size) = init(codec.max_message_bytes)?;
        if size != nodes + 1 {
            return Err(NetError::Io {
                what: "--transport mpi".into(),
                msg: format!(
                    "this MPI job has {size} process(es) for --nodes {nodes}: run under \
                     `mpirun -n {} ...` (the coordinator and one process per node)",
                    nodes + 1
                ),
            });
        }
        let me = if rank == 0 {
            NodeId::from(nodes)
        } else {
            NodeId::from(rank - 1)
        };
        Ok(MpiTransport {
            me,
            nodes,
            codec,
            peers: Mutex::new(
                (0..=nodes)
                    .map(|_| Peer {
                        said_goodbye: false,
                        essential: false,
                    })
                    .collect(),
            ),
            stats: Mutex::new(WireStats::default()),
            failed: Mutex::new(None),
            closed: Mutex::new(false),
        })
    }

    fn world(&self) -> NetResult<&'static World> {
        match WORLD.get() {
            Some(Ok(w)) => Ok(w),
            _ => Err(NetError::Disconnected { rank: self.me }),
        }
    }

    fn mpi_rank(&self, n: NodeId) -> i32 {
        if n.index() == self.nodes {
            0
        } else {
            n.index() as i32 + 1
        }
    }

    fn node_of(&self, mpi_rank: i32) -> NodeId {
        if mpi_rank == 0 {
            NodeId::from(self.nodes)
        } else {
            NodeId::from(mpi_rank as usize - 1)
        }
    }

    fn fail(&self, peer: NodeId, reason: String) -> NetError {
        let name = self.peer_name(peer);
        let mut f = lock(&self.failed);
        if f.is_none() {
            *f = Some((name.clone(), reason.clone()));
        }
        NetError::PeerLost { peer: name, reason }
    }

    /// An inbox item as a message, `None` (a benign goodbye), or an error.
    fn take(&self, item: Incoming) -> NetResult<Option<Envelope>> {
        match item {
            Incoming::Msg { from, tag, bytes } => {
                let kind = MessageKind::from_code(tag as u8).unwrap_or(MessageKind::Control);
                let mut s = lock(&self.stats);
                s.payload.record_recv(kind, bytes.len() as u64);
                s.wire_bytes_recv += bytes.len() as u64;
                Ok(Some(Envelope {
                    from: self.node_of(from),
                    to: self.me,
                    kind,
                    payload: bytes,
                }))
            }
            Incoming::Goodbye(r) => {
                let n = self.node_of(r);
                let essential = {
                    let mut peers = lock(&self.peers);
                    let p = &mut peers[n.index()];
                    p.said_goodbye = true;
                    p.essential
                };
                if essential {
                    Err(self.fail(n, "said Goodbye before it was done".into()))
                } else {
                    Ok(None)
                }
            }
            Incoming::Lost(r, why) => Err(self.fail(self.node_of(r), why)),
        }
    }
}

impl Transport for MpiTransport {
    fn rank(&self) -> NodeId {
        self.me
    }

    fn size(&self) -> usize {
        self.nodes + 1
    }

    fn send(&self, to: NodeId, kind: MessageKind, payload: Vec<u8>) -> NetResult<()> {
        check_rank(to, self.nodes + 1)?;
        let n = payload.len() as u64;
        if n > self.codec.max_message_bytes {
            return Err(NetError::TooLarge {
                kind,
                size: n,
                limit: self.codec.max_message_bytes,
            });
        }
        if lock(&self.peers)[to.index()].said_goodbye {
            // Like a message to a stopped actor: dropped.
            return Ok(());
        }
        let w = self.world()?;
        w.cmd
            .send(Command::Send {
                to: self.mpi_rank(to),
                tag: i32::from(kind.code()),
                bytes: payload,
            })
            .map_err(|_| NetError::Disconnected { rank: self.me })?;
        let mut s = lock(&self.stats);
        s.payload.record_send(to, kind, n);
        s.wire_bytes_sent += n;
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

impl RemoteTransport for MpiTransport {
    fn peer_name(&self, rank: NodeId) -> String {
        if rank.index() == self.nodes {
            "the coordinator (MPI rank 0)".into()
        } else {
            format!("worker {} (MPI rank {})", rank.index(), rank.index() + 1)
        }
    }

    fn set_essential(&self, rank: NodeId, essential: bool) {
        if let Some(p) = lock(&self.peers).get_mut(rank.index()) {
            p.essential = essential;
        }
    }

    fn stats(&self) -> WireStats {
        lock(&self.stats).clone()
    }

    /// Goodbye to every rank, then waits (at most `wait`) for the sends to
    /// leave and every rank's goodbye, and finalizes MPI (`MPI_Finalize`
    /// waits for every rank to finalize). Once per process.
    fn close(&self, wait: Duration) {
        let mut closed = lock(&self.closed);
        if *closed {
            return;
        }
        *closed = true;
        let Ok(w) = self.world() else { return };
        let (tx, rx) = crossbeam_channel::bounded(1);
        if w.cmd.send(Command::Close(wait, tx)).is_ok() {
            let _ = rx.recv();
        }
        if let Some(h) = lock(&w.thread).take() {
            let _ = h.join();
        }
    }

    /// MPI cannot tell a death from a hang (a dead rank ends the job):
    /// `Some(true)` for ranks that said goodbye, `None` for the others.
    fn link_endings(&self, wait: Duration) -> Vec<Option<bool>> {
        let until = Instant::now() + wait;
        loop {
            let open = lock(&self.peers)
                .iter()
                .enumerate()
                .any(|(k, p)| k != self.me.index() && !p.said_goodbye);
            let left = until.saturating_duration_since(Instant::now());
            if !open || left.is_zero() {
                break;
            }
            let Ok(w) = self.world() else { break };
            match w.inbox.recv_timeout(left) {
                Ok(Incoming::Goodbye(r)) => {
                    let n = self.node_of(r);
                    lock(&self.peers)[n.index()].said_goodbye = true;
                }
                Ok(_) => {}
                Err(_) => break,
            }
        }
        lock(&self.peers)
            .iter()
            .enumerate()
            .map(|(k, p)| (k != self.me.index() && p.said_goodbye).then_some(true))
            .collect()
    }
}

impl Inbox for MpiTransport {
    type Item = Incoming;
    fn me(&self) -> NodeId {
        self.me
    }
    fn inbox(&self) -> NetResult<&Receiver<Incoming>> {
        Ok(&self.world()?.inbox)
    }
    fn failed(&self) -> &Mutex<Option<(String, String)>> {
        &self.failed
    }
    fn take(&self, item: Incoming) -> NetResult<Option<Envelope>> {
        MpiTransport::take(self, item)
    }
}
