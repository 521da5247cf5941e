//! Where a cluster's nodes run, from the transport options: worker
//! processes spawned on this machine (`processes`), workers at the
//! addresses given (`tcp`), or the ranks of an MPI job (`mpi`, one frame
//! per job). The option struct ([`TransportArgs`]) only parses; spawning
//! and dialling are here.

use std::path::Path;
use std::time::Duration;

use crate::cluster::remote::{Coordinator, LiveCluster, LocalWorkers, Measured};
use crate::cluster::{ClusterConfig, ClusterOutcome};
use crate::job::transport_args::{read_hostfile, OnFailure, TransportArgs, TransportKind};
use crate::net::tcp::Token;
use crate::render::RenderInput;

/// A session's remote nodes: the live cluster and, for `processes`, the
/// children it runs on (ended and reaped when this is dropped, after the
/// session's `End`).
pub struct RemoteNodes {
    /// The cluster of workers, connected at its first frame.
    pub live: LiveCluster,
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
/// of `exe` (this program, or `pvrsim` from a test) for `processes`, the
/// listed workers for `tcp`.
pub fn open(
    net: &TransportArgs,
    kind: TransportKind,
    n: usize,
    exe: &Path,
) -> anyhow::Result<RemoteNodes> {
    match kind {
        TransportKind::Processes => {
            // One session, unless a loss may need a second of the survivors.
            let once = net.on_failure != OnFailure::Reassign;
            let children = spawn_processes(net, exe, n, once)?;
            let live = LiveCluster::new(local_coordinator(net, &children));
            Ok(RemoteNodes {
                live,
                children: Some(children),
            })
        }
        TransportKind::Tcp => Ok(RemoteNodes {
            live: LiveCluster::new(tcp_coordinator(net, n)?),
            children: None,
        }),
        other => anyhow::bail!(
            "a persistent session runs on --transport processes or tcp, not {} (internal error)",
            other.name()
        ),
    }
}

/// This program's path (the workers' program for `processes`).
pub fn this_program() -> anyhow::Result<std::path::PathBuf> {
    use anyhow::Context;
    std::env::current_exe().context("cannot find this program's path")
}

/// Starts the `processes` children: `n` workers of `exe` with the
/// heartbeat deadline (and `--test-worker-hook`'s arguments for its
/// rank). With `once` they serve one session (`--once`: they exit after
/// it), else every session until they are killed (a retry after a loss is
/// a new session of the survivors).
pub fn spawn_processes(
    net: &TransportArgs,
    exe: &Path,
    n: usize,
    once: bool,
) -> anyhow::Result<LocalWorkers> {
    let extra = vec![
        "--heartbeat-timeout".to_string(),
        net.heartbeat_timeout.to_string(),
    ];
    let hook = net.worker_hook()?;
    let hook = hook.as_ref().map(|(r, a)| (*r, a.as_slice()));
    LocalWorkers::spawn_hooked(exe, n, &extra, hook, Duration::from_secs(30), once)
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

/// One mesh frame over worker processes of `exe` (a session of one frame),
/// the children ended after it.
pub fn run_processes(
    net: &TransportArgs,
    exe: &Path,
    input: &RenderInput,
    cfg: &ClusterConfig,
) -> anyhow::Result<(ClusterOutcome, Measured)> {
    let mut nodes = open(net, TransportKind::Processes, cfg.phase1.nodes, exe)?;
    let out = nodes
        .live
        .frame(crate::cluster::remote::Work::Cells(input, 0), cfg)?;
    nodes.close()?;
    Ok(out)
}

/// One mesh frame under `--transport mpi` (MPI rank 0; the other ranks
/// serve a node for the frame: [`TransportArgs::serve_mpi_worker`]). An
/// error is printed and ends every rank of the job.
pub fn run_mpi(
    net: &TransportArgs,
    input: &RenderInput,
    cfg: &ClusterConfig,
) -> anyhow::Result<(ClusterOutcome, Measured)> {
    #[cfg(feature = "mpi")]
    {
        let recv_timeout = Duration::from_secs_f64(net.recv_timeout);
        match crate::cluster::remote::mpi::coordinate(input, cfg, recv_timeout) {
            Ok(x) => Ok(x),
            // Print here, then end every rank of the job.
            Err(e) => {
                eprint!("{}", crate::job::error_text(&e));
                crate::net::mpi::abort(1)
            }
        }
    }
    #[cfg(not(feature = "mpi"))]
    {
        let _ = (net, input, cfg);
        anyhow::bail!(crate::job::transport_args::NO_MPI)
    }
}
