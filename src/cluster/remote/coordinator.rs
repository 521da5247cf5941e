//! The TCP coordinator: connects to `N` workers (concurrently), hands each
//! its set-up and, when its cache misses, its cells (by content hash): the
//! links of a session ([`super::live`]), whose frames run over its
//! [`TcpTransport`] with the transport-independent driver
//! ([`super::drive`]).
//!
//! Every failure names the worker and the phase and ends the run with an
//! error; the caller (the CLI) exits non-zero. Nothing waits without a
//! deadline: connects and handshakes have a timeout, links have
//! heartbeats, receives have `recv_timeout`.

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::live::{LiveCluster, Work};
use super::measured::Measured;
use super::pieces::PieceSet;
use super::reassign::{endings_wait, lost_on, LostWorkers};
use super::session::Session;
use crate::cluster::{ClusterConfig, ClusterOutcome};
use crate::net::tcp::{self, Link, Role, TcpOptions, TcpTransport, Token};
use crate::net::{Codec, NodeId, RemoteTransport};
use crate::render::RenderInput;
use crate::scene::Scene;

/// How the coordinator reaches its workers.
#[derive(Debug, Clone)]
pub struct Coordinator {
    /// Worker addresses, one per node, by rank.
    pub workers: Vec<String>,
    /// The shared token.
    pub token: Token,
    /// Link timing.
    pub tcp: TcpOptions,
    /// Longest wait for a message in phase 1 (a protocol deadlock).
    pub recv_timeout: Duration,
    /// `--on-failure reassign`: when workers die in phase 1, the frame runs
    /// again on the survivors with the dead workers' cells split among them
    /// (the workers must serve more than one session: not `--once`).
    pub reassign: bool,
}

impl Coordinator {
    /// Runs one frame on the workers (a session of one frame, see
    /// [`LiveCluster`]); with [`Coordinator::reassign`], again on the
    /// survivors whenever workers are lost (at any phase).
    pub fn run(
        &self,
        input: &RenderInput,
        cfg: &ClusterConfig,
    ) -> anyhow::Result<(ClusterOutcome, Measured)> {
        self.check_count(cfg)?;
        let mut live = LiveCluster::new(self.clone());
        let out = live.frame(Work::Cells(input, 0), cfg)?;
        live.end();
        Ok(out)
    }

    /// Runs one frame on workers that read their own pieces of `pieces`
    /// (node `k` a contiguous run, [`PieceSet::parts`]); with
    /// [`Coordinator::reassign`], again on the survivors whenever workers
    /// are lost, the lost workers' pieces read by the survivors.
    pub fn run_pieces(
        &self,
        pieces: &PieceSet,
        scene: &Scene,
        cfg: &ClusterConfig,
    ) -> anyhow::Result<(ClusterOutcome, Measured)> {
        self.check_count(cfg)?;
        let mut live = LiveCluster::new(self.clone());
        let out = live.frame(Work::Pieces(pieces, scene), cfg)?;
        live.end();
        Ok(out)
    }

    /// One worker address per node.
    pub(super) fn check_count(&self, cfg: &ClusterConfig) -> anyhow::Result<()> {
        let n = cfg.phase1.nodes;
        anyhow::ensure!(
            self.workers.len() == n,
            "--nodes {n} needs {n} workers; {} worker addresses were given",
            self.workers.len()
        );
        Ok(())
    }

    /// Connects to the workers `ranks` (indices into [`Self::workers`]) and
    /// hands each its set-up (and its cells when its cache misses), all
    /// concurrently: the session's links. Counts the cells sent in
    /// `measured`.
    pub(super) fn connect(
        &self,
        ranks: &[usize],
        setups: Vec<(super::session::WorkerSetup, Vec<u8>)>,
        busy_wait: Duration,
        measured: &mut Measured,
    ) -> anyhow::Result<TcpTransport> {
        let n = ranks.len();
        let rt = tcp::runtime()?;
        let me = NodeId::from(n);
        let mut tasks = Vec::with_capacity(n);
        for (k, (setup, cells)) in setups.into_iter().enumerate() {
            let addr = self.workers[ranks[k]].clone();
            let token = self.token.clone();
            let opts = self.tcp;
            tasks.push(rt.spawn(async move {
                let name = format!("worker {k} ({addr})");
                let to = NodeId::from(k);
                let msg = Session::Setup(Box::new(setup));
                let (s, sent) =
                    hand_setup(&addr, &name, &token, &opts, me, to, &msg, cells, busy_wait).await?;
                Ok((
                    Link {
                        rank: to,
                        name,
                        stream: s,
                    },
                    sent,
                ))
            }));
        }
        let mut links = Vec::with_capacity(n);
        for (l, sent) in join_setups(&rt, tasks, "a set-up task", |k| {
            format!("worker {k} ({})", self.workers[ranks[k]])
        })? {
            measured.cells_bytes_sent += sent;
            measured.cells_cached += usize::from(sent == 0);
            links.push(l);
        }
        Ok(TcpTransport::new(
            Arc::clone(&rt),
            me,
            n + 1,
            links,
            self.tcp,
        )?)
    }

    /// The workers whose links ended without `Goodbye`, as an error
    /// context for the phase the frame was in (see [`lost_on`]).
    pub(super) fn lost_workers(
        &self,
        t: &impl RemoteTransport,
        n: usize,
        e: anyhow::Error,
        phase: &str,
    ) -> anyhow::Error {
        lost_on(
            t,
            0,
            n,
            endings_wait(self.reassign, self.tcp.deadline),
            e,
            phase,
        )
    }
}

/// Connects to a worker at `addr` (`name` in errors) as the coordinator
/// (rank `me`; the worker is rank `to`), sends `setup`, reads its cache
/// answer and sends `payload` (cells or bricks) if it asks. A worker that
/// answers "busy" serves another coordinator, or is still ending an
/// earlier attempt of this frame: it is asked again every 100 ms for up to
/// `busy_wait` (see [`busy_wait`]), then the answer is an error. Returns
/// the stream and the payload bytes sent (0 on a cache hit).
#[allow(clippy::too_many_arguments)]
pub(super) async fn hand_setup(
    addr: &str,
    name: &str,
    token: &tcp::Token,
    opts: &TcpOptions,
    me: NodeId,
    to: NodeId,
    setup: &Session,
    payload: Vec<u8>,
    busy_wait: Duration,
) -> anyhow::Result<(tokio::net::TcpStream, u64)> {
    let codec = Codec::default();
    let until = Instant::now() + busy_wait;
    loop {
        let (mut s, hello) = tcp::connect(addr, token, Role::Coordinator, me.0, opts)
            .await
            .map_err(|e| anyhow::anyhow!("{name}, set-up: {e}"))?;
        anyhow::ensure!(
            hello.role == Role::Worker,
            "{name}, set-up: answered as {:?}, not as a worker",
            hello.role
        );
        tcp::raw::write_msg_within(&mut s, &codec, me, to, setup, name, opts.deadline).await?;
        // A worker answers at once (a cache look-up): silence for the
        // heartbeat deadline is a stalled worker.
        let need: Session = tcp::raw::read_msg(&mut s, &codec, opts.deadline, name).await?;
        return match need {
            Session::Need(true) => {
                let len = payload.len() as u64;
                let cells = Session::Cells(payload);
                tcp::raw::write_msg_within(&mut s, &codec, me, to, &cells, name, opts.deadline)
                    .await?;
                Ok((s, len))
            }
            Session::Need(false) => Ok((s, 0)),
            Session::Failed(why) if why.starts_with("busy") && Instant::now() < until => {
                drop(s);
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
            Session::Failed(why) => anyhow::bail!("{name}, set-up: {why}"),
            other => anyhow::bail!("{name}, set-up: sent {other:?} instead of Need"),
        };
    }
}

/// How long an attempt asks a busy worker again: not at all on the first
/// attempt of a frame ("busy" is an error naming the worker: it serves
/// another coordinator), twice the heartbeat `deadline` plus 2 s on a
/// retry after a loss (the survivors may still be ending the failed
/// attempt: they notice the closed links within the deadline).
pub(super) fn busy_wait(retry: bool, deadline: Duration) -> Duration {
    if retry {
        deadline * 2 + Duration::from_secs(2)
    } else {
        Duration::ZERO
    }
}

/// Waits for every one of the set-up tasks, one per worker by rank, and gives
/// their values in rank order. When tasks
/// fail, the error (the first in rank order) carries the ranks of every
/// failed task as [`LostWorkers`] (phase `set-up`; `name` names a rank's
/// worker), for `--on-failure reassign`.
pub(super) fn join_setups<T>(
    rt: &tokio::runtime::Runtime,
    tasks: Vec<tokio::task::JoinHandle<anyhow::Result<T>>>,
    what: &str,
    name: impl Fn(usize) -> String,
) -> anyhow::Result<Vec<T>> {
    let mut out = Vec::with_capacity(tasks.len());
    let mut first_err = None;
    let mut lost = LostWorkers {
        phase: "set-up".into(),
        ..Default::default()
    };
    for (k, t) in tasks.into_iter().enumerate() {
        let e = match rt.block_on(t) {
            Ok(Ok(v)) => {
                out.push(v);
                continue;
            }
            Ok(Err(e)) => e,
            Err(e) => anyhow::anyhow!("{what} failed: {e}"),
        };
        lost.ranks.push(k);
        lost.names.push(name(k));
        first_err.get_or_insert(e);
    }
    match first_err {
        Some(e) => Err(e.context(lost)),
        None => Ok(out),
    }
}
