//! `--transport mpi` (cargo feature `mpi`): the frame under `mpirun -n N+1`,
//! MPI rank 0 the coordinator, ranks `1..=N` the nodes `0..N`. Every rank
//! runs the same `pvrsim cluster ...` command line; the CLI sends ranks
//! `≥ 1` to [`serve_worker`] before it loads anything.
//!
//! The set-up goes over the transport itself (MPI already connects every
//! rank): the coordinator sends each worker its `Setup` and its `Cells`
//! (no cache: one frame per job), then both sides run the same drivers as
//! over TCP ([`super::drive::drive`], [`super::worker::run_node`]); phase 2
//! goes worker to worker.
//!
//! Failure: a rank that dies ends the job (`mpirun`'s default); a rank that
//! stalls is caught by the receive deadlines. The rank that sees an error
//! prints it; the coordinator then ends the job with `MPI_Abort`
//! ([`crate::net::mpi::abort`]), a worker tells the coordinator and, if
//! the job is still up after a grace period, aborts it itself.

use std::time::{Duration, Instant};

use anyhow::Context;

use super::drive::{drive, worker_setups, DriveOptions};
use super::hooks::Hooks;
use super::measured::Measured;
use super::session::{sha256, Session, WorkerSetup};
use super::worker::run_node;
use crate::cluster::{ClockKind, ClusterConfig, ClusterOutcome};
use crate::net::mpi::MpiTransport;
use crate::net::{Codec, MessageKind, NodeId, RemoteTransport, Transport};
use crate::render::RenderInput;

/// Longest wait of a worker for its set-up: the coordinator loads the
/// data first.
fn setup_wait(recv_timeout: Duration) -> Duration {
    recv_timeout.max(Duration::from_secs(300))
}

/// The coordinator's frame (MPI rank 0).
pub fn coordinate(
    input: &RenderInput,
    cfg: &ClusterConfig,
    recv_timeout: Duration,
) -> anyhow::Result<(ClusterOutcome, Measured)> {
    let n = cfg.phase1.nodes;
    let codec = Codec::default();
    let t = MpiTransport::new(n, codec)?;
    let me = NodeId::from(n);
    anyhow::ensure!(
        t.rank() == me,
        "the coordinator runs on MPI rank 0, not on {}",
        t.rank()
    );
    let mut cfg = cfg.clone();
    cfg.phase1.clock = ClockKind::Wall;
    let t_setup = Instant::now();
    let placement = crate::cluster::place(input, &cfg);
    let names: Vec<String> = (1..=n).map(|r| format!("MPI rank {r}")).collect();
    let mut measured = Measured::default();
    for (k, (setup, cells)) in worker_setups(input, &cfg, &placement, &names, codec, recv_timeout)
        .into_iter()
        .enumerate()
    {
        let to = NodeId::from(k);
        measured.cells_bytes_sent += cells.len() as u64;
        t.send(
            to,
            MessageKind::Session,
            codec.encode(&Session::Setup(Box::new(setup)))?,
        )
        .with_context(|| format!("set-up of {}", t.peer_name(to)))?;
        t.send(
            to,
            MessageKind::Session,
            codec.encode(&Session::Cells(cells))?,
        )
        .with_context(|| format!("set-up of {}", t.peer_name(to)))?;
    }
    let d = DriveOptions {
        ready_wait: recv_timeout,
        recv_timeout,
    };
    let out = drive(
        &t,
        d,
        crate::cluster::FrameData::Mesh(input),
        &cfg,
        t_setup,
        measured,
        |_, e, _| e,
    )?;
    // MPI workers serve one frame: they close after it.
    t.close(Duration::from_secs(2));
    Ok(out)
}

/// A worker rank (`≥ 1`): receives its set-up and cells, runs its node
/// for one frame, finalizes. On an error it tells the coordinator, prints
/// the error and, if the coordinator has not ended the job within 10 s,
/// ends it (`MPI_Abort`). Returns only on success.
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
            let why = format!("{e:#}");
            eprintln!("pvrsim (MPI worker {}): {why}", t.rank());
            let coord = NodeId::from(nodes);
            if let Ok(b) = codec.encode(&Session::Failed(why)) {
                let _ = t.send(coord, MessageKind::Session, b);
            }
            std::thread::sleep(Duration::from_secs(10));
            crate::net::mpi::abort(1)
        }
    }
}

fn worker(t: &MpiTransport, nodes: usize, recv_timeout: Duration) -> anyhow::Result<()> {
    let codec = Codec::default();
    let coord = NodeId::from(nodes);
    t.set_essential(coord, true);
    let wait = setup_wait(recv_timeout);
    let next = |what: &str| -> anyhow::Result<Session> {
        let e = t
            .recv_timeout(wait)?
            .ok_or_else(|| anyhow::anyhow!("no {what} from the coordinator within {wait:?}"))?;
        anyhow::ensure!(
            e.from == coord && e.kind == MessageKind::Session,
            "{} sent a {} message before the set-up was done",
            t.peer_name(e.from),
            e.kind
        );
        codec
            .decode::<Session>(&e.payload)
            .map_err(|err| anyhow::anyhow!("the coordinator's {what}: {err}"))
    };
    let setup: WorkerSetup = match next("set-up")? {
        Session::Setup(s) => *s,
        other => anyhow::bail!("the coordinator sent {other:?} instead of the set-up"),
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
    let cells = match next("cells")? {
        Session::Cells(c) => c,
        other => anyhow::bail!("the coordinator sent {other:?} instead of the cells"),
    };
    anyhow::ensure!(
        sha256(&cells) == setup.cells_sha256,
        "the cells from the coordinator do not match their SHA-256"
    );
    run_node(t, &setup, &cells, &mut None, wait, Hooks::default())?;
    t.close(Duration::from_secs(10));
    Ok(())
}
