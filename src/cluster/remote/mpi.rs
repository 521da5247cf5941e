//! `--transport mpi` (cargo feature `mpi`): a session under `mpirun -n
//! N+1`, MPI rank 0 the coordinator ([`MpiCluster`]), ranks `1..=N` the
//! nodes `0..N` ([`serve_worker`]). Every rank runs the same `pvrsim
//! cluster ...` command line; the CLI sends ranks `≥ 1` to
//! [`serve_worker`] before it loads anything.
//!
//! MPI already connects every rank, so the session's links are the
//! transport itself, set up once (MPI initialised once). Each frame the
//! coordinator sends every rank its `Setup` (camera, transfer function,
//! options: a few KB); a rank answers `Need`: its cells come once (a mesh
//! rank 0 read, cached by SHA-256 for the frames of one data state), or
//! it reads **its own pieces** of a `.pvtu` at the first frame and keeps
//! them (rank 0 reads the `.pvtu` and the pieces' vertices, never their
//! cells, [`super::pieces`]); then both sides run the same drivers as over
//! TCP ([`super::drive::drive`], [`super::worker::run_node`]), phase 2
//! worker to worker. Between frames the ranks exchange `Flush`es
//! ([`super::worker::next`]); `End` ends the session and every rank
//! finalizes.
//!
//! Failure (MPI is fail-stop: no ULFM in rsmpi): a rank that dies ends the
//! job (`mpirun`'s default); a rank that stalls is caught by the receive
//! deadlines (`--recv-timeout`), on rank 0 for the whole frame. The rank
//! that sees an error prints it naming the rank; the coordinator then ends
//! the job with `MPI_Abort` ([`crate::net::mpi::abort`], the CLI's
//! `abort_on_error`), a worker tells the coordinator and, if the job is
//! still up after a grace period, aborts it itself.

use std::time::{Duration, Instant};

use super::drive::{cell_setups, drive, part_cells, piece_setups, DriveOptions};
use super::hooks::Hooks;
use super::live::Work;
use super::measured::Measured;
use super::session::{Session, WorkerSetup};
use super::worker::{next, run_node, Held};
use crate::cluster::{ClockKind, ClusterConfig, ClusterOutcome, FrameData};
use crate::net::mpi::MpiTransport;
use crate::net::{Codec, MessageKind, NodeId, RemoteTransport, Transport};
use crate::node::Placement;

/// Longest wait of a worker for its first set-up: the coordinator loads
/// the data first.
fn setup_wait(recv_timeout: Duration) -> Duration {
    recv_timeout.max(Duration::from_secs(300))
}

/// Longest wait for the ranks' `Ready` when they read their own pieces.
const PIECES_READY_WAIT: Duration = Duration::from_secs(600);

/// The coordinator's side of an MPI session (MPI rank 0): the ranks are
/// connected by MPI; each [`MpiCluster::frame`] sends their set-ups and
/// runs the frame.
pub struct MpiCluster {
    t: MpiTransport,
    n: usize,
    recv_timeout: Duration,
    /// Every set-up of the session carries it.
    session_id: [u8; 16],
    /// The data state's key, the placement parts and their encoded cells
    /// (with their hashes), kept while frames share them.
    encoded: Option<(u64, Vec<Vec<u32>>, Vec<(Vec<u8>, [u8; 32])>)>,
    /// Frames run.
    frames: usize,
    /// After `End`, or after a failed frame (nothing more is sent).
    ended: bool,
}

impl MpiCluster {
    /// The session of `n` node ranks (this process must be MPI rank 0 of
    /// `n + 1`).
    pub fn new(n: usize, recv_timeout: Duration) -> anyhow::Result<MpiCluster> {
        let t = MpiTransport::new(n, Codec::default())?;
        let me = NodeId::from(n);
        anyhow::ensure!(
            t.rank() == me,
            "the coordinator runs on MPI rank 0, not on {}",
            t.rank()
        );
        Ok(MpiCluster {
            t,
            n,
            recv_timeout,
            session_id: super::session::new_session_id(),
            encoded: None,
            frames: 0,
            ended: false,
        })
    }

    /// One frame on the ranks: their set-ups (cells when a rank needs
    /// them), then the frame as over TCP. An error names the rank; the
    /// caller ends the job (`MPI_Abort`).
    pub fn frame(
        &mut self,
        work: Work<'_>,
        cfg: &ClusterConfig,
    ) -> anyhow::Result<(ClusterOutcome, Measured)> {
        anyhow::ensure!(!self.ended, "the MPI session has ended");
        let n = self.n;
        anyhow::ensure!(
            cfg.phase1.nodes == n,
            "--nodes {}: this MPI session has {n} node ranks",
            cfg.phase1.nodes
        );
        let mut cfg = cfg.clone();
        cfg.phase1.clock = ClockKind::Wall;
        let t_setup = Instant::now();
        let codec = Codec::default();
        let names: Vec<String> = (1..=n).map(|r| format!("MPI rank {r}")).collect();
        let (setups, data) = match work {
            Work::Cells(input, key) => {
                // A placement that does not follow the camera is the same
                // for every frame of a data state.
                let kept = self.encoded.as_ref().is_some_and(|(k, parts, _)| {
                    *k == key
                        && parts.len() == n
                        && cfg.placement != crate::node::PlacementMethod::RcbView
                });
                let parts = match &self.encoded {
                    Some((_, parts, _)) if kept => parts.clone(),
                    _ => crate::cluster::place(input, &cfg).parts,
                };
                let p = Placement { parts };
                if !self
                    .encoded
                    .as_ref()
                    .is_some_and(|(k, parts, _)| *k == key && *parts == p.parts)
                {
                    self.encoded = Some((key, p.parts.clone(), part_cells(input, &p)));
                }
                let (_, _, cells) = self.encoded.as_ref().expect("encoded above");
                let s = cell_setups(input, &cfg, &p, cells, &names, codec, self.recv_timeout);
                (s, FrameData::Mesh(input))
            }
            Work::Pieces(pieces, scene) => {
                let depth_range = pieces.depth_range(scene)?;
                let parts = pieces.parts(n);
                let s = piece_setups(
                    pieces,
                    scene,
                    depth_range,
                    &cfg,
                    &parts,
                    &names,
                    codec,
                    self.recv_timeout,
                );
                let data = FrameData::Pieces {
                    scene,
                    cells: 0,
                    depth_range,
                };
                (s, data)
            }
        };
        let mut cells = Vec::with_capacity(n);
        for (k, (mut setup, c)) in setups.into_iter().enumerate() {
            setup.session_id = self.session_id;
            let to = NodeId::from(k);
            self.t.set_essential(to, true);
            self.t
                .send(
                    to,
                    MessageKind::Session,
                    codec.encode(&Session::Setup(Box::new(setup)))?,
                )
                .map_err(|e| anyhow::anyhow!("set-up of {}: {e}", self.t.peer_name(to)))?;
            cells.push(Some(c));
        }
        // The first frame waits for the ranks to read or decode their
        // data; a later one, whose ranks hold it, for the deadline only.
        let ready_wait = match work {
            _ if self.frames > 0 => self.recv_timeout,
            Work::Pieces(..) => PIECES_READY_WAIT.max(self.recv_timeout),
            Work::Cells(..) => setup_wait(self.recv_timeout),
        };
        let d = DriveOptions {
            ready_wait,
            recv_timeout: self.recv_timeout,
            cells,
        };
        let r = drive(
            &self.t,
            d,
            data,
            &cfg,
            t_setup,
            Measured::default(),
            |_, e, _| e,
        );
        match &r {
            Ok(_) => self.frames += 1,
            // MPI is fail-stop: no goodbyes to wait for; the caller ends
            // the job (`MPI_Abort`).
            Err(_) => self.ended = true,
        }
        r
    }

    /// Ends the session: `End` to every rank, then MPI finalizes (every
    /// rank's goodbye awaited, at most 10 s).
    pub fn end(&mut self) {
        if self.ended {
            return;
        }
        self.ended = true;
        if let Ok(b) = Codec::default().encode(&Session::End) {
            for k in 0..self.n {
                let _ = self
                    .t
                    .send(NodeId::from(k), MessageKind::Session, b.clone());
            }
        }
        for k in 0..self.n {
            self.t.set_essential(NodeId::from(k), false);
        }
        self.t.close(Duration::from_secs(10));
    }
}

impl Drop for MpiCluster {
    fn drop(&mut self) {
        self.end();
    }
}

/// A worker rank (`≥ 1`): serves the session's frames until the
/// coordinator's `End`, then finalizes. On an error it tells the
/// coordinator, prints the error and, if the coordinator has not ended
/// the job within 10 s, ends it (`MPI_Abort`). Returns only on success.
pub fn serve_worker(nodes: usize, recv_timeout: Duration) -> anyhow::Result<()> {
    let codec = Codec::default();
    let t = match MpiTransport::new(nodes, codec) {
        Ok(t) => t,
        Err(e) => {
            // A wrong `-n`: every rank sees it; rank 0 reports it and aborts.
            std::thread::sleep(Duration::from_secs(10));
            eprintln!("pvrsim (MPI worker): {e}");
            crate::net::mpi::abort(1)
        }
    };
    match worker(&t, nodes, recv_timeout) {
        Ok(()) => Ok(()),
        Err(e) => {
            let why = format!("MPI rank {}: {e:#}", t.rank().index() + 1);
            eprintln!("pvrsim (MPI worker): {why}");
            let coord = NodeId::from(nodes);
            if let Ok(b) = codec.encode(&Session::Failed(why)) {
                let _ = t.send(coord, MessageKind::Session, b);
            }
            std::thread::sleep(Duration::from_secs(10));
            crate::net::mpi::abort(1)
        }
    }
}

/// The session's frames on a worker rank.
fn worker(t: &MpiTransport, nodes: usize, recv_timeout: Duration) -> anyhow::Result<()> {
    let codec = Codec::default();
    let coord = NodeId::from(nodes);
    t.set_essential(coord, true);
    let wait = setup_wait(recv_timeout);
    let e = t
        .recv_timeout(wait)?
        .ok_or_else(|| anyhow::anyhow!("no set-up from the coordinator within {wait:?}"))?;
    anyhow::ensure!(
        e.from == coord && e.kind == MessageKind::Session,
        "{} sent a {} message before the set-up",
        t.peer_name(e.from),
        e.kind
    );
    let mut setup: WorkerSetup = match codec.decode::<Session>(&e.payload) {
        Ok(Session::Setup(s)) => *s,
        Ok(other) => anyhow::bail!("the coordinator sent {other:?} instead of the set-up"),
        Err(err) => anyhow::bail!("the coordinator's set-up: {err}"),
    };
    setup
        .validate()
        .map_err(|e| anyhow::anyhow!("bad set-up from the coordinator: {e}"))?;
    anyhow::ensure!(
        NodeId(setup.rank) == t.rank() && setup.nodes as usize == nodes,
        "the set-up is for node {} of {}, but this is {} of {nodes}",
        setup.rank,
        setup.nodes,
        t.rank()
    );
    let mut held: Option<Held> = None;
    let mut cells = Vec::new();
    loop {
        if let Some(c) = need_cells(t, &setup, held.as_ref(), codec, recv_timeout)? {
            held = None;
            cells = c;
        }
        run_node(t, &setup, &cells, &mut held, wait, Hooks::default())?;
        match next::next_frame(t, &setup, codec, recv_timeout)? {
            next::Next::End => break,
            next::Next::Frame(s) => {
                if s.pieces != setup.pieces {
                    held = None;
                }
                setup = *s;
            }
        }
    }
    t.close(Duration::from_secs(10));
    Ok(())
}

/// A frame's `Need`: `None` when the rank's data stays (the same cells, or
/// pieces, which it reads itself); else the cells from the coordinator,
/// checked against their SHA-256.
fn need_cells(
    t: &MpiTransport,
    setup: &WorkerSetup,
    held: Option<&Held>,
    codec: Codec,
    wait: Duration,
) -> anyhow::Result<Option<Vec<u8>>> {
    let coord = NodeId(setup.nodes);
    let kept = setup.pieces.is_some() || held.is_some_and(|h| h.key == setup.cells_sha256);
    t.send(
        coord,
        MessageKind::Session,
        codec.encode(&Session::Need(!kept))?,
    )?;
    if kept {
        return Ok(None);
    }
    next::recv_cells(t, coord, &setup.cells_sha256, codec, wait).map(Some)
}
