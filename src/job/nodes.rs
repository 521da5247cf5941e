//! Where a cluster's nodes run, from the transport options: worker
//! processes spawned on this machine (`processes`), workers at the
//! addresses given (`tcp`), or the ranks of an MPI job (`mpi`: rank 0 is
//! the coordinator, the other ranks serve their nodes,
//! [`serve_mpi_worker`]). The option struct ([`TransportArgs`]) only
//! parses; spawning, dialling and starting MPI are here.

use std::time::Duration;

use crate::cluster::remote::spawn::WorkerProgram;
use crate::cluster::remote::{Coordinator, LiveCluster, LiveNodes, LocalWorkers, Measured};
use crate::cluster::{ClusterConfig, ClusterOutcome};
use crate::job::args::transport::{read_hostfile, OnFailure, TransportArgs, TransportKind};
use crate::net::tcp::Token;
use crate::render::RenderInput;

/// A session's remote nodes: the live cluster and, for `processes`, the
/// children it runs on (ended and reaped when this is dropped, after the
/// session's `End`).
pub struct RemoteNodes {
    /// The session's nodes: workers connected at the first frame, or the
    /// ranks of the MPI job.
    pub live: LiveNodes,
    /// The worker processes started for it (`processes` only).
    pub children: Option<LocalWorkers>,
}

impl RemoteNodes {
    /// Ends the session: `End` to the workers, then the children (if any)
    /// must exit cleanly within 10 s.
    pub fn close(mut self) -> anyhow::Result<()> {
        self.live.end();
        if let Some(w) = self.children.as_mut().filter(|w| w.once) {
            let bad = w.finish(Duration::from_secs(10));
            anyhow::ensure!(
                bad.is_empty(),
                "worker processes {bad:?} did not exit cleanly"
            );
        }
        Ok(())
    }
}

/// The nodes of `net`'s transport `kind` for `n` nodes: worker processes
/// of `program` (this program, `python -m pvrsim` under the Python module,
/// or `pvrsim` from a test) for `processes`, the listed workers for `tcp`.
pub fn open(
    net: &TransportArgs,
    kind: TransportKind,
    n: usize,
    program: &WorkerProgram,
) -> anyhow::Result<RemoteNodes> {
    match kind {
        TransportKind::Processes => {
            // One session, unless a loss may need a second of the survivors.
            let once = net.on_failure != OnFailure::Reassign;
            let children = spawn_processes(net, program, n, once)?;
            let live = LiveNodes::Links(LiveCluster::new(local_coordinator(net, &children)));
            Ok(RemoteNodes {
                live,
                children: Some(children),
            })
        }
        TransportKind::Tcp => Ok(RemoteNodes {
            live: LiveNodes::Links(LiveCluster::new(tcp_coordinator(net, n)?)),
            children: None,
        }),
        TransportKind::Mpi => Ok(RemoteNodes {
            live: mpi_nodes(net, n)?,
            children: None,
        }),
        other => anyhow::bail!(
            "a persistent session runs on --transport processes, tcp or mpi, not {} (internal error)",
            other.name()
        ),
    }
}

/// Starts the `processes` children: `n` workers of `program` with the
/// heartbeat deadline (and `--test-worker-hook`'s arguments for its
/// rank). With `once` they serve one session (`--once`: they exit after
/// it), else every session until they are killed (a retry after a loss is
/// a new session of the survivors).
pub fn spawn_processes(
    net: &TransportArgs,
    program: &WorkerProgram,
    n: usize,
    once: bool,
) -> anyhow::Result<LocalWorkers> {
    let extra = vec![
        "--heartbeat-timeout".to_string(),
        net.heartbeat_timeout.to_string(),
    ];
    let hook = net.worker_hook()?;
    let hook = hook.as_ref().map(|(r, a)| (*r, a.as_slice()));
    LocalWorkers::spawn_hooked(program, n, &extra, hook, Duration::from_secs(30), once)
}

/// The coordinator of worker processes started on this machine.
pub fn local_coordinator(net: &TransportArgs, workers: &LocalWorkers) -> Coordinator {
    Coordinator {
        workers: workers.addrs.clone(),
        token: workers.token().clone(),
        tcp: net.tcp_options(),
        recv_timeout: Duration::from_secs_f64(net.recv_timeout),
        reassign: net.on_failure == OnFailure::Reassign,
    }
}

/// `--transport tcp`'s workers (`--workers` or `--hostfile`, one per
/// node, `n` of them) and the token (`--token-file`, or none: loopback
/// workers only).
pub fn tcp_workers(net: &TransportArgs, n: usize) -> anyhow::Result<(Vec<String>, Token)> {
    let (workers, given) = match &net.hostfile {
        Some(p) => (read_hostfile(p)?, format!("{} lists", p.display())),
        None => (net.workers.clone(), "--workers lists".to_string()),
    };
    anyhow::ensure!(
        !workers.is_empty(),
        "--transport tcp needs --workers host:port,... or --hostfile FILE"
    );
    anyhow::ensure!(
        workers.len() == n,
        "--nodes {n} needs {n} workers; {given} {}: give one worker per node",
        workers.len()
    );
    let token = match &net.token_file {
        Some(p) => Token::load(p)?,
        None => Token::none(),
    };
    Ok((workers, token))
}

/// The coordinator of `--transport tcp`'s workers ([`tcp_workers`]).
pub fn tcp_coordinator(net: &TransportArgs, n: usize) -> anyhow::Result<Coordinator> {
    let (workers, token) = tcp_workers(net, n)?;
    Ok(Coordinator {
        workers,
        token,
        tcp: net.tcp_options(),
        recv_timeout: Duration::from_secs_f64(net.recv_timeout),
        reassign: net.on_failure == OnFailure::Reassign,
    })
}

/// One mesh frame over worker processes of `program` (a session of one
/// frame), the children ended after it.
pub fn run_processes(
    net: &TransportArgs,
    program: &WorkerProgram,
    input: &RenderInput,
    cfg: &ClusterConfig,
) -> anyhow::Result<(ClusterOutcome, Measured)> {
    let mut nodes = open(net, TransportKind::Processes, cfg.phase1.nodes, program)?;
    let out = nodes
        .live
        .frame(crate::cluster::remote::Work::Cells(input, 0), cfg)?;
    nodes.close()?;
    Ok(out)
}

/// The receive deadline of `net` (`--recv-timeout`; 60 s when unset).
#[cfg(feature = "mpi")]
fn recv_timeout(net: &TransportArgs) -> Duration {
    Duration::from_secs_f64(if net.recv_timeout.is_finite() && net.recv_timeout > 0.0 {
        net.recv_timeout
    } else {
        60.0
    })
}

/// The node ranks of an MPI job, this process rank 0 (`mpirun -n N+1`).
fn mpi_nodes(net: &TransportArgs, n: usize) -> anyhow::Result<LiveNodes> {
    #[cfg(feature = "mpi")]
    {
        crate::net::mpi::init(crate::net::DEFAULT_MAX_MESSAGE_BYTES)?;
        Ok(LiveNodes::Mpi(
            crate::cluster::remote::mpi::MpiCluster::new(n, recv_timeout(net))?,
        ))
    }
    #[cfg(not(feature = "mpi"))]
    {
        let _ = (net, n);
        anyhow::bail!(crate::job::args::transport::NO_MPI)
    }
}

/// Under `--transport mpi`, on an MPI rank other than 0: serves this
/// rank's node for every frame of the session and returns `true` (the
/// caller then does nothing else: rank 0 writes the images and the
/// reports). `false` on rank 0 and for every other transport. Call it
/// before loading anything. Without the `mpi` feature, `--transport mpi`
/// is an error saying how to build with it.
pub fn serve_mpi_worker(net: &TransportArgs, nodes: usize) -> anyhow::Result<bool> {
    if net.transport != Some(TransportKind::Mpi) {
        return Ok(false);
    }
    #[cfg(feature = "mpi")]
    {
        let (rank, _) = crate::net::mpi::init(crate::net::DEFAULT_MAX_MESSAGE_BYTES)?;
        if rank == 0 {
            return Ok(false);
        }
        crate::cluster::remote::mpi::serve_worker(nodes, recv_timeout(net))?;
        Ok(true)
    }
    #[cfg(not(feature = "mpi"))]
    {
        let _ = nodes;
        anyhow::bail!(crate::job::args::transport::NO_MPI)
    }
}

/// Under `--transport mpi`, rank 0: prints `e` and ends every rank of the
/// job (`MPI_Abort`, exit code 1), so that no rank is left waiting for a
/// frame that will not come. Other transports: returns `e`.
pub fn abort_on_error(net: &TransportArgs, e: anyhow::Error) -> anyhow::Error {
    #[cfg(feature = "mpi")]
    if net.transport == Some(TransportKind::Mpi) {
        eprint!("{}", crate::job::error_text(&e));
        crate::net::mpi::abort(1)
    }
    let _ = net;
    e
}
