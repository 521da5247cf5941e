//! The coordinator's frame over any [`RemoteTransport`], once every worker
//! holds its set-up and cells: `Ready` from all, `Go`, the
//! [`ManagerActor`] as rank `N` with the same driver loop as the threads
//! ([`run_actor`]), every node's results, phase 2 worker to worker
//! ([`super::phase2`]), the gathered pixels, and the report, built with the
//! same code as the other clocks ([`crate::cluster::finish_with`]). TCP
//! ([`super::coordinator`]) and MPI (`super::mpi`) connect and hand out
//! the set-up differently, then share this.
//!
//! Every failure names the worker and the phase and ends the run with an
//! error. Nothing waits without a deadline.

use std::time::{Duration, Instant};

use anyhow::Context;

use super::guard::{take_blame, SessionGuard};
use super::measured::Measured;
use super::phase2::{exec_options, replay_plan, stats_from_logs, Gather, RankLog};
use super::pieces::PieceSet;
use super::session::{sha256, NodeResult, Session, WorkerSetup};
use crate::cluster::phase2::Phase2;
use crate::cluster::{ClusterConfig, ClusterOutcome, FrameData, Phase1Parts};
use crate::manager::{ManagerActor, ManagerConfig};
use crate::net::{
    run_actor, Codec, ComputeMode, MessageKind, NodeId, RemoteTransport, SimTrace, TrafficStats,
    WallClock, WallOptions, WireStats,
};
use crate::node::{NodeRenderer, Placement, WorkUnit};
use crate::render::cell::PreparedTf;
use crate::render::RenderInput;
use crate::scene::Scene;

/// Each placement part's cells with their vertex data, encoded, and the
/// SHA-256 of the bytes (the workers' cache key), encoded in parallel.
pub(super) fn part_cells(input: &RenderInput, placement: &Placement) -> Vec<(Vec<u8>, [u8; 32])> {
    use rayon::prelude::*;
    placement
        .parts
        .par_iter()
        .map(|part| {
            let cells = WorkUnit::from_mesh(&input.mesh, &input.s_norm, part).encode();
            let hash = sha256(&cells);
            (cells, hash)
        })
        .collect()
}

/// Each worker's set-up and encoded cells for `placement`, the parts'
/// cells encoded before ([`part_cells`], kept across a session's frames;
/// `addrs`: the workers' addresses, or names, by rank).
#[allow(clippy::too_many_arguments)]
pub(super) fn cell_setups(
    input: &RenderInput,
    cfg: &ClusterConfig,
    placement: &Placement,
    cells: &[(Vec<u8>, [u8; 32])],
    addrs: &[String],
    codec: Codec,
    recv_timeout: Duration,
) -> Vec<(WorkerSetup, Vec<u8>)> {
    let n = cfg.phase1.nodes;
    let p1 = cfg.phase1;
    let overlap = p1.overlap && !p1.share && p1.node.ert.enabled();
    let pairwise = if overlap {
        placement.footprints(input).pairwise
    } else {
        Vec::new()
    };
    let base = base_setup(
        &input.scene,
        crate::cluster::phase1::depth_range(input),
        cfg,
        addrs,
        codec,
        recv_timeout,
    );
    let mut out = Vec::with_capacity(n);
    for (k, (part, (cells, hash))) in placement.parts.iter().zip(cells).enumerate() {
        let peers: Vec<u32> = if overlap {
            (0..n)
                .filter(|&b| b != k && pairwise[k].get(b).is_some_and(|&p| p > 0))
                .map(|b| b as u32)
                .collect()
        } else {
            Vec::new()
        };
        let setup = WorkerSetup {
            rank: k as u32,
            overlap_peers: peers,
            cells_initial: part.len() as u64,
            cells_sha256: *hash,
            ..base.clone()
        };
        out.push((setup, cells.clone()));
    }
    out
}

/// Each worker's set-up when the workers read their own pieces: node `k`
/// the pieces `parts[k]` of `pieces` (no cells to send).
#[allow(clippy::too_many_arguments)]
pub(super) fn piece_setups(
    pieces: &PieceSet,
    scene: &Scene,
    depth_range: [f32; 2],
    cfg: &ClusterConfig,
    parts: &[Vec<u32>],
    addrs: &[String],
    codec: Codec,
    recv_timeout: Duration,
) -> Vec<(WorkerSetup, Vec<u8>)> {
    let base = base_setup(scene, depth_range, cfg, addrs, codec, recv_timeout);
    parts
        .iter()
        .enumerate()
        .map(|(k, part)| {
            let setup = WorkerSetup {
                rank: k as u32,
                pieces: Some(pieces.source(part)),
                ..base.clone()
            };
            (setup, Vec::new())
        })
        .collect()
}

/// What every worker's set-up of a frame shares (rank 0, no cells).
fn base_setup(
    scene: &Scene,
    depth_range: [f32; 2],
    cfg: &ClusterConfig,
    addrs: &[String],
    codec: Codec,
    recv_timeout: Duration,
) -> WorkerSetup {
    let p1 = cfg.phase1;
    WorkerSetup {
        rank: 0,
        nodes: p1.nodes as u32,
        peers: addrs.to_vec(),
        scene_toml: scene.to_toml(&scene.data.path.to_string_lossy()),
        depth_range,
        node: p1.node.into(),
        share: p1.share,
        dlb: p1.dlb,
        policy: p1.policy.into(),
        overlap_peers: Vec::new(),
        profile: cfg.profile,
        list_codec: cfg.codec,
        compositor: cfg.compositor,
        max_message_bytes: codec.max_message_bytes,
        cells_initial: 0,
        cells_sha256: [0; 32],
        pieces: None,
        recv_timeout_s: recv_timeout.as_secs_f64(),
        session_id: super::session::new_session_id(),
    }
}

/// Timing of a coordinator's frame.
#[derive(Debug, Clone, Default)]
pub(super) struct DriveOptions {
    /// A session's later frame: each worker's encoded cells, sent when it
    /// answers its set-up with `Need(true)` (its `Need` comes with the
    /// `Ready`s of the others, over the session's links). Empty on a
    /// frame whose set-ups were handed out before.
    pub cells: Vec<Option<Vec<u8>>>,
    /// Longest wait for every worker's `Ready` (set-up and mesh).
    pub ready_wait: Duration,
    /// Longest wait for a message in phases 1 and 2 (a protocol deadlock).
    pub recv_timeout: Duration,
}

/// A set-up error `e` that names a worker which gave up (a `Goodbye`) when
/// another one died (its link closed without `Goodbye`): names the dead one
/// first, since the others' errors follow from it. Waits at most 2 s for
/// the links' endings.
fn blame_the_dead<T: RemoteTransport>(t: &T, n: usize, e: anyhow::Error) -> anyhow::Error {
    let text = format!("{e:#}");
    let dead = |endings: Vec<Option<bool>>| -> Vec<String> {
        (0..n)
            .filter(|&k| endings.get(k) == Some(&Some(false)))
            .map(|k| t.peer_name(NodeId::from(k)))
            .collect()
    };
    // The error comes from a death it names already: no need to wait.
    let now = dead(t.link_endings(Duration::ZERO));
    if !now.is_empty() && now.iter().all(|d| text.contains(d.as_str())) {
        return e;
    }
    let dead = dead(t.link_endings(Duration::from_secs(2)));
    if dead.is_empty() || dead.iter().all(|d| text.contains(d.as_str())) {
        return e;
    }
    e.context(format!(
        "{} closed the connection without Goodbye (died or was killed); what follows is a consequence",
        dead.join(", ")
    ))
}

/// The coordinator's frame over `t` (rank `n`, workers `0..n`), once every
/// worker has its set-up and cells: `Ready` from all, `Go`, the manager in
/// phase 1, the results, phase 2 worker to worker, the report.
/// `on_error` may attach what the transport knows of a failure (which
/// workers died) and gets the phase it happened in. `t_setup` is when the
/// set-up began.
pub(super) fn drive<T: RemoteTransport>(
    t: &T,
    d: DriveOptions,
    data: FrameData<'_>,
    cfg: &ClusterConfig,
    t_setup: Instant,
    measured: Measured,
    on_error: impl FnOnce(&T, anyhow::Error, &'static str) -> anyhow::Error,
) -> anyhow::Result<(ClusterOutcome, Measured)> {
    let mut phase = "set-up";
    drive_phases(t, d, data, cfg, t_setup, measured, &mut phase).map_err(|e| on_error(t, e, phase))
}

/// [`drive`]'s body; `phase` follows the frame (`set-up`, `phase 1`,
/// `collecting results`, `phase 2`) so that an error can be placed.
fn drive_phases<T: RemoteTransport>(
    t: &T,
    mut d: DriveOptions,
    mut data: FrameData<'_>,
    cfg: &ClusterConfig,
    t_setup: Instant,
    mut measured: Measured,
    phase: &mut &'static str,
) -> anyhow::Result<(ClusterOutcome, Measured)> {
    let n = cfg.phase1.nodes;
    let cfg = cfg.clone();
    let codec = Codec::default();
    for k in 0..n {
        t.set_essential(NodeId::from(k), true);
    }
    // Ready from everyone, then Go.
    let mut ready = vec![false; n];
    let mut initial = vec![0u64; n];
    let wait = d.ready_wait;
    let mut cells = std::mem::take(&mut d.cells);
    while ready.iter().any(|r| !r) {
        let e = t
            .recv_timeout(wait)
            .map_err(|e| blame_the_dead(t, n, anyhow::Error::from(e)))
            .context("set-up (joining the mesh)")?
            .ok_or_else(|| {
                let missing: Vec<usize> = (0..n).filter(|&k| !ready[k]).collect();
                anyhow::anyhow!("set-up: workers {missing:?} did not join the mesh within {wait:?}")
            })?;
        let k = e.from.index();
        match codec.decode::<Session>(&e.payload) {
            Ok(Session::Ready { remaining }) if k < n => {
                ready[k] = true;
                initial[k] = remaining;
            }
            // A session's later frame: the worker's cache answer.
            Ok(Session::Need(need)) if k < cells.len() && !ready[k] => {
                let c = cells[k].take().unwrap_or_default();
                if need {
                    measured.cells_bytes_sent += c.len() as u64;
                    t.send(
                        e.from,
                        MessageKind::Session,
                        codec.encode(&Session::Cells(c))?,
                    )
                    .context("set-up (sending cells)")?;
                } else {
                    measured.cells_cached += 1;
                }
            }
            Ok(Session::Failed(why)) => {
                anyhow::bail!("set-up: {} failed: {why}", t.peer_name(e.from))
            }
            Ok(Session::Lost(r)) => {
                let (who, why) = take_blame(t, e.from, &r);
                anyhow::bail!("set-up: {who} {why}")
            }
            _ => anyhow::bail!(
                "set-up: {} sent a {} message instead of Ready",
                t.peer_name(e.from),
                e.kind
            ),
        }
    }
    measured.setup_s = t_setup.elapsed().as_secs_f64();
    if let FrameData::Pieces { cells, .. } = &mut data {
        // The workers read the cells: their counts are the frame's.
        *cells = initial.iter().sum();
    }
    let go = codec.encode(&Session::Go)?;
    for k in 0..n {
        t.send(NodeId::from(k), MessageKind::Session, go.clone())
            .context("set-up (sending Go)")?;
    }

    // Phase 1: the manager here, the nodes on the workers.
    *phase = "phase 1";
    let mut manager = manager_for(data, &cfg, initial)?;
    let wire0 = t.stats();
    let t1 = Instant::now();
    let phase1 = (|| {
        let (m_stop, m_trace, m_traffic) = run_actor(
            &SessionGuard::new(t, codec),
            &mut manager,
            WallClock::start(),
            WallOptions {
                compute: ComputeMode::Skip,
                recv_timeout: d.recv_timeout,
            },
        )
        .context("phase 1 (scan conversion, ERT sharing, load balancing)")?;
        if let Some(e) = &manager.stats().error {
            anyhow::bail!("phase 1 failed at the manager: {e}");
        }

        // Results.
        *phase = "collecting results";
        let t_collect = Instant::now();
        let mut results: Vec<Option<NodeResult>> = (0..n).map(|_| None).collect();
        while results.iter().any(Option::is_none) {
            let e = t
                .recv_timeout(d.recv_timeout)
                .context("collecting the nodes' results")?
                .ok_or_else(|| {
                    let missing: Vec<usize> = (0..n).filter(|&k| results[k].is_none()).collect();
                    anyhow::anyhow!(
                        "collecting results: workers {missing:?} sent nothing within {:?}",
                        d.recv_timeout
                    )
                })?;
            let k = e.from.index();
            match codec.decode::<Session>(&e.payload) {
                Ok(Session::Failed(why)) => {
                    anyhow::bail!("collecting results: {} failed: {why}", t.peer_name(e.from))
                }
                Ok(Session::Lost(r)) => {
                    let (who, why) = take_blame(t, e.from, &r);
                    anyhow::bail!("collecting results: {who} {why}")
                }
                Ok(Session::Result(r)) if k < n => {
                    results[k] = Some(*r);
                }
                // Late phase-1 traffic to the stopped manager is dropped,
                // as in the other drivers.
                _ if e.kind != MessageKind::Session => {}
                _ => anyhow::bail!(
                    "collecting results: {} sent a message that is not its result",
                    t.peer_name(e.from)
                ),
            }
        }
        Ok((m_stop, m_trace, m_traffic, results, t_collect))
    })();
    let (m_stop, m_trace, m_traffic, results, t_collect) = phase1?;
    let host_s = t1.elapsed().as_secs_f64();
    measured.collect_s = t_collect.elapsed().as_secs_f64();
    let wire_m = {
        let mut w = t.stats();
        w.wire_bytes_sent -= wire0.wire_bytes_sent;
        w.wire_bytes_recv -= wire0.wire_bytes_recv;
        w.payload = m_traffic.clone();
        w
    };
    for (k, r) in results.iter().enumerate() {
        if let Some(e) = r.as_ref().and_then(|r| r.raw.error()) {
            anyhow::bail!(
                "phase 1 failed at node {k} ({}): {e}",
                t.peer_name(NodeId::from(k))
            );
        }
    }

    // Phase 2, worker to worker; the pixels come here.
    *phase = "phase 2";
    let t2 = Instant::now();
    let (ph2, logs) = phase2(t, d, data.scene(), &cfg, codec, &mut measured)?;
    measured.phase2_s = t2.elapsed().as_secs_f64();

    let mut nodes = Vec::with_capacity(n);
    let mut stopped_at = Vec::with_capacity(n + 1);
    let mut trace = SimTrace::default();
    let mut traffic = TrafficStats::default();
    let mut wire = WireStats::default();
    for (k, r) in results.into_iter().enumerate() {
        let r = r.ok_or_else(|| anyhow::anyhow!("no result from worker {k}"))?;
        nodes.push(r.raw);
        stopped_at.push(Some(r.stopped_at));
        trace.events.extend(r.trace.events);
        trace.cpu.extend(r.trace.cpu);
        traffic.merge(&r.traffic);
        wire.merge(&r.wire);
    }
    stopped_at.push(Some(m_stop));
    trace.events.extend(m_trace.events);
    trace.cpu.extend(m_trace.cpu);
    trace
        .events
        .sort_by(|a, b| a.start.total_cmp(&b.start).then(a.node.cmp(&b.node)));
    traffic.merge(&m_traffic);
    wire.merge(&wire_m);
    measured.phase1 = wire;
    let end_s = stopped_at[..n]
        .iter()
        .flatten()
        .fold(0.0f64, |a, &b| a.max(b));
    measured.phase2_handoff_bytes = logs.iter().map(|l| l.handoff_bytes).sum();
    measured.phase2_ranks = logs
        .iter()
        .map(|l| super::measured::RankTimes {
            wall_s: l.seconds,
            cpu_s: l.cpu_s,
            compress_s: l.compress_s,
        })
        .collect();
    measured.phase2_handoff_messages = logs.iter().map(|l| l.handoff_messages).sum();
    let out = crate::cluster::finish_with(
        data,
        &cfg,
        Phase1Parts {
            nodes,
            lists: Vec::new(),
            manager: manager.stats().clone(),
            end_s,
            stopped_at,
            trace,
            traffic,
            host_s,
        },
        None,
        ph2,
        measured.phase2_s,
    )?;
    Ok((out, measured))
}

/// Starts phase 2 on every worker, takes the gathered pixels and every
/// worker's log; returns phase 2 as [`crate::cluster::phase2::run`]
/// would (image, counters, network replay) and the logs.
fn phase2<T: RemoteTransport>(
    t: &T,
    d: DriveOptions,
    scene: &Scene,
    cfg: &ClusterConfig,
    codec: Codec,
    measured: &mut Measured,
) -> anyhow::Result<(Phase2, Vec<RankLog>)> {
    let n = cfg.phase1.nodes;
    let strategy = cfg.compositor.build();
    let list_codec = cfg.codec.build();
    let schedule = strategy.schedule(
        n,
        crate::compositor::region::screen(scene.image.width, scene.image.height),
    );
    let opts = exec_options(cfg.phase1.node.partial_composition, scene);
    let go = codec.encode(&Session::Composite)?;
    for k in 0..n {
        t.send(NodeId::from(k), MessageKind::Session, go.clone())
            .context("phase 2 (starting it)")?;
    }
    let mut gather = Gather::new(&schedule, list_codec.as_ref(), opts);
    let mut logs: Vec<Option<RankLog>> = vec![None; n];
    while logs.iter().any(Option::is_none) {
        let e = t
            .recv_timeout(d.recv_timeout)
            .context("phase 2 (compositing)")?
            .ok_or_else(|| {
                let missing: Vec<usize> = (0..n).filter(|&k| logs[k].is_none()).collect();
                anyhow::anyhow!(
                    "phase 2 (compositing): workers {missing:?} did not finish within {:?}",
                    d.recv_timeout
                )
            })?;
        let k = e.from.index();
        match e.kind {
            MessageKind::Image if k < n => gather.take(k, &e.payload)?,
            MessageKind::Session => match codec.decode::<Session>(&e.payload) {
                Ok(Session::Phase2Done(d)) if k < n && logs[k].is_none() => {
                    let (log, wire) = *d;
                    measured.phase2.merge(&wire);
                    logs[k] = Some(log);
                    t.set_essential(e.from, false);
                }
                Ok(Session::Failed(why)) => anyhow::bail!(
                    "phase 2 (compositing): {} failed: {why}",
                    t.peer_name(e.from)
                ),
                Ok(Session::Lost(r)) => {
                    let (who, why) = take_blame(t, e.from, &r);
                    anyhow::bail!("phase 2 (compositing): {who} {why}")
                }
                _ => anyhow::bail!(
                    "phase 2 (compositing): {} sent a session message out of turn",
                    t.peer_name(e.from)
                ),
            },
            // Late phase-1 traffic to the stopped manager is dropped.
            _ => {}
        }
    }
    let logs: Vec<RankLog> = logs.into_iter().flatten().collect();
    let image = gather.image()?;
    let stats = stats_from_logs(&schedule, strategy.name(), list_codec.name(), &logs);
    let (sim, bytes_sent, busy_s) =
        replay_plan(&schedule, &logs, &cfg.profile).run(&cfg.network, cfg.phase1.record_trace)?;
    Ok((
        Phase2 {
            image,
            stats,
            sim,
            bytes_sent,
            busy_s,
        },
        logs,
    ))
}

/// The manager for a run, as [`crate::cluster::phase1::run`] builds it:
/// table shape and level grid from a node renderer of the same options.
fn manager_for(
    data: FrameData<'_>,
    cfg: &ClusterConfig,
    initial: Vec<u64>,
) -> anyhow::Result<ManagerActor> {
    let p1 = &cfg.phase1;
    let scene = data.scene();
    let mut probe = NodeRenderer::new(scene.view(), PreparedTf::new(&scene.transfer), p1.node);
    if p1.share {
        probe.enable_level_sharing();
        let [z0, z1] = data.depth_range();
        probe.enable_pixel_sharing(crate::node::pixel_share::DepthQuant::new(z0, z1));
    }
    let (nx, ny) = probe.table_dims();
    let mcfg = ManagerConfig {
        nodes: p1.nodes,
        table_dims: (nx as u16, ny as u16),
        dlb: p1.dlb,
        min_grant: p1.policy.min_grant as u64,
        levels: if p1.share { probe.level_grid() } else { None },
        pixels: if p1.share {
            probe.pixel_share_shape()
        } else {
            None
        },
        help_gap: match probe.depth_span() {
            Some(span) if p1.share && p1.dlb && p1.policy.help_gap > 0.0 => {
                Some(p1.policy.help_gap * span)
            }
            _ => None,
        },
        // Remote workers run partitioned, nearest-first (no release ordering).
        release: None,
    };
    Ok(ManagerActor::new(
        mcfg,
        initial,
        cfg.profile,
        Codec::default(),
    ))
}
