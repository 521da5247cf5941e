//! The run report (`--report run.json`). Keys scripts rely on: `frame_s`,
//! `tsc_max_s`, `tsc_mean_s`, `imbalance`, `share_s_total`, `composite_s`,
//! `bytes_total`, `bytes_by_kind`, `t_share`, `share_efficiency`,
//! `ideal_speedup`, `nodes[]`. Host-time measurements, which vary from run
//! to run, are under `wall` only; in virtual-clock mode everything else is a
//! deterministic function of the inputs. In wall-clock mode **every** time
//! key holds a host measurement, never a modelled one (one report, one
//! clock): phase 1 from the threads' timeline, phase 2 the in-process
//! compositor's host time (all nodes' work on one thread, so per-node
//! `composite_s` is `null`), the manager's busy time from its spans, the
//! sequential reference measured on one thread; `network` and `profile`
//! then read `n/a (wall clock)`, since neither model is used for a time.
//!
//! Terms (also printed by [`summary`]):
//! - **Tsc**: a node's scan-conversion time, the end of its last scan chunk
//!   in phase 1 (no compositing); `tsc_max_s` is the slowest node's, the
//!   paper's Table 2 figure.
//! - **speed-up (Tsc)** `speedup` = sequential ÷ Tsc max; **speed-up
//!   (frame)** `speedup_frame` = sequential ÷ frame (phase 1 + phase 2):
//!   what a user waits for. The sequential run is one node holding every
//!   cell, same ERT settings, same clock.
//! - **ideal speed-up** = Base Tsc max ÷ (sequential ÷ N): the speed-up over
//!   Base (ERT, sharing, DLB off at the same N) of a cluster that skipped as
//!   much as the sequential ERT run and split it perfectly.
//! - **share efficiency** = cells skipped by ERT on all nodes ÷ cells
//!   skipped by the sequential run (1: the cluster skips as much as one
//!   machine that sees every cell).

use std::collections::BTreeMap;

use serde::Serialize;

use super::phase2::Phase2;
use super::{ClockKind, ClusterConfig};
use crate::compositor::CompositeStats;
use crate::manager::ManagerStats;
use crate::net::{MessageKind, SimTrace, TraceKind, TrafficStats};
use crate::node::{NodeActor, NodeStats};
use crate::render::RenderInput;

/// Reference runs for the ratios.
#[derive(Debug, Clone, Copy)]
pub struct References {
    /// Modelled seconds of the sequential run (one node, every cell).
    pub seq_s: f64,
    /// Cells it skipped by ERT.
    pub seq_skipped: u64,
    /// `tsc_max_s` of the Base cluster (`None`: this run is Base).
    pub base_tsc_max_s: Option<f64>,
}

/// A node's numbers taken from its actor before phase 2 (serde: a worker
/// process sends them to the coordinator).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct NodeRaw {
    stats: NodeStats,
    processed: u64,
    skipped: u64,
    culled: u64,
    stored: u64,
}

impl NodeRaw {
    /// The node's first error, if it failed.
    pub fn error(&self) -> Option<&str> {
        self.stats.error.as_deref()
    }

    /// Reads the actor.
    pub fn from_actor(a: &NodeActor) -> NodeRaw {
        let t = a.renderer().totals();
        NodeRaw {
            stats: a.stats().clone(),
            processed: a.renderer().processed() as u64,
            skipped: t.cells_skipped_ert,
            culled: t.cells_culled,
            stored: a
                .renderer()
                .lists()
                .lists()
                .iter()
                .map(|l| l.len() as u64)
                .sum(),
        }
    }
}

/// One node's line of the report.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct NodeReport {
    /// Rank.
    pub rank: usize,
    /// Scan-conversion time: end of the node's last scan chunk (s).
    pub tsc_s: f64,
    /// Busy seconds scanning (chunks + ERT updates).
    pub scan_s: f64,
    /// Of which ERT table updates.
    pub update_s: f64,
    /// Seconds applying shared tables.
    pub share_s: f64,
    /// Seconds packing/unpacking stolen cells.
    pub steal_s: f64,
    /// Phase-1 seconds with nothing to do (phase-1 end − busy).
    pub idle_s: f64,
    /// Phase-2 compute seconds (merging and compositing), modelled; `null`
    /// on the wall clock (the host composites all nodes on one thread).
    pub composite_s: Option<f64>,
    /// Cells placed on the node.
    pub cells_initial: u64,
    /// Cells processed (tested, skipped or scanned), own and taken.
    pub cells_processed: u64,
    /// Of which skipped by ERT.
    pub cells_skipped_ert: u64,
    /// Cells culled on arrival (empty, off screen).
    pub cells_culled: u64,
    /// Cells given away (DLB).
    pub cells_given: u64,
    /// Cells taken from others (DLB).
    pub cells_taken: u64,
    /// ERT tables sent to the manager.
    pub shares_sent: u64,
    /// Work requests sent.
    pub requests_sent: u64,
    /// Payload bytes sent, phases 1 and 2.
    pub bytes_sent: u64,
    /// Of which phase 1.
    pub bytes_sent_phase1: u64,
    /// List entries (segments or merged pieces) the node holds at the end
    /// of phase 1: its list memory, 24 bytes each.
    pub segments_stored: u64,
}

/// Cost of the ERT exchanges: per exchange, from the share leaving the
/// node's NIC to the reply arriving at it (virtual clock; wall: between the
/// zero-length send and receive marks).
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct TShare {
    /// Exchanges.
    pub exchanges: usize,
    /// Mean seconds.
    pub mean_s: f64,
    /// Longest.
    pub max_s: f64,
    /// Every exchange, node by node (omitted above 20,000).
    pub per_exchange_s: Vec<f64>,
}

/// Host-time measurements (vary from run to run).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct WallInfo {
    /// Host seconds of phase 1 (simulation or threads).
    pub host_phase1_s: f64,
    /// Host seconds of phase 2 (real compositing plus its replay).
    pub host_phase2_s: f64,
}

/// The report of one cluster run.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ClusterReport {
    /// Scene image size.
    pub image: [u32; 2],
    /// Cells in the mesh.
    pub cells_total: u64,
    /// Number of nodes (the manager is extra).
    pub n_nodes: usize,
    /// `virtual` or `wall`.
    pub clock: ClockKind,
    /// Network model name (`n/a (wall clock)` when no time is modelled).
    pub network: String,
    /// Cost profile name (`n/a (wall clock)` when no time is modelled).
    pub profile: String,
    /// Placement method.
    pub placement: String,
    /// Compositing strategy.
    pub compositor: String,
    /// Codec.
    pub codec: String,
    /// ERT threshold (1 = off).
    pub ert_threshold: f32,
    /// ERT table divisions D.
    pub ert_table: u32,
    /// ERT update constant C.
    pub ert_update: u32,
    /// Weak sharing on (only with ERT), through the manager or overlap.
    pub share: bool,
    /// ERT sharing mode: `off`, `manager` or `overlap`.
    pub sharing: String,
    /// Level sharing ([`crate::node::levels`]): opacity levels per block
    /// (1 with `share_sub` 1: the paper's per-entry table).
    pub share_levels: u8,
    /// Level sharing: blocks per entry axis.
    pub share_sub: u8,
    /// Most ERT shares in flight per node (0: no limit, the paper's protocol).
    pub share_window: u32,
    /// ERT structure nodes test against: `pyramid` (per-pixel, with
    /// per-pixel level sharing) or `flat` (the paper's table).
    pub ert_structure: String,
    /// Front-first help gap, fraction of the depth range (0: off).
    pub help_gap: f32,
    /// Front-first help forwards the manager sent.
    pub help_forwards: u64,
    /// Where the cells live: `replicated` (the whole mesh on every node;
    /// DLB and help move cell ids) or `partitioned` (cells move with their
    /// vertices).
    pub data: crate::node::DataMode,
    /// Replicated data: the one-time cost of putting the whole mesh on every
    /// node (not part of any frame time).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub replication: Option<Replication>,
    /// DLB on.
    pub dlb: bool,
    /// Nodes kept canonical lists (image independent of the distribution).
    pub canonical: bool,
    /// Phase 1 + phase 2 (s).
    pub frame_s: f64,
    /// End of phase 1: the last node told to finish (s).
    pub phase1_s: f64,
    /// Slowest node's scan-conversion time (the paper's Table 2 figure).
    pub tsc_max_s: f64,
    /// Mean over nodes.
    pub tsc_mean_s: f64,
    /// Fastest node.
    pub tsc_min_s: f64,
    /// `tsc_max / tsc_mean − 1`.
    pub imbalance: f64,
    /// Sum over nodes of seconds applying shared tables.
    pub share_s_total: f64,
    /// Sum over nodes of DLB packing/unpacking seconds.
    pub steal_s_total: f64,
    /// Sum over nodes of phase-1 idle seconds.
    pub idle_s_total: f64,
    /// Phase 2 (compositing and gather to rank 0), seconds.
    pub composite_s: f64,
    /// Payload bytes of all messages, both phases.
    pub bytes_total: u64,
    /// Payload bytes per message kind (`ert-share`, `ert-reply`,
    /// `work-request`, `work-grant`, `segments`, `image`, `control`).
    pub bytes_by_kind: BTreeMap<String, u64>,
    /// Messages per kind.
    pub messages_by_kind: BTreeMap<String, u64>,
    /// ERT exchange times.
    pub t_share: TShare,
    /// The manager.
    pub manager: ManagerStats,
    /// Modelled seconds the manager spent merging tables (`manager.busy_s`):
    /// compare with `phase1_s` to see when it is the bottleneck.
    pub manager_busy_s: f64,
    /// Manager shards `K` (`--manager-shards`; 1: one manager).
    pub manager_shards: usize,
    /// Busy seconds of the busiest manager shard (shard 0, the manager,
    /// included; `manager_busy_s` when `K = 1`). Per shard:
    /// `manager.shard_busy_s`.
    pub shard_busy_max_s: f64,
    /// List entries held by all nodes at the end of phase 1 (sum of
    /// `nodes[].segments_stored`).
    pub segments_stored: u64,
    /// Cells processed by all nodes (a cell given away is counted once, by its taker).
    pub cells_processed: u64,
    /// Cells skipped by ERT on all nodes.
    pub cells_skipped_ert: u64,
    /// Cells moved by DLB.
    pub cells_moved: u64,
    /// Global front-to-back schedule ([`crate::node::schedule`]): waves
    /// used (0: off).
    pub schedule_waves: usize,
    /// Global schedule: cells per leaf.
    pub schedule_leaf_cells: usize,
    /// Global schedule: the placement's stacking along the view the nodes
    /// computed (`null`: no schedule computed).
    pub schedule_stacking: Option<f64>,
    /// Global schedule: applied (stacking at least the threshold).
    pub schedule_applied: bool,
    /// Global schedule: cells dealt to another node than their placement
    /// part's (computed on every node; no byte travels).
    pub cells_scheduled: u64,
    /// Modelled seconds of the sequential run at the same settings.
    pub sequential_s: Option<f64>,
    /// Cells it skipped by ERT.
    pub sequential_skipped: Option<u64>,
    /// `tsc_max_s` of Base (ERT, sharing, DLB off) at the same N.
    pub base_tsc_max_s: Option<f64>,
    /// Cells skipped by all nodes ÷ cells skipped by the sequential run
    /// (1: the cluster skips as much as one machine; `null` without ERT).
    pub share_efficiency: Option<f64>,
    /// Base `tsc_max_s` ÷ (sequential time / N).
    pub ideal_speedup: Option<f64>,
    /// Sequential time ÷ `tsc_max_s` (scan conversion only, the paper's measure).
    pub speedup: Option<f64>,
    /// `speedup / N`.
    pub efficiency: Option<f64>,
    /// Sequential time ÷ `frame_s` (phase 1 + compositing: what a user waits for).
    pub speedup_frame: Option<f64>,
    /// `speedup_frame / N`.
    pub efficiency_frame: Option<f64>,
    /// The compositor's counters (bytes per round, raw vs encoded).
    pub compositing: CompositeStats,
    /// One line per node.
    pub nodes: Vec<NodeReport>,
    /// Host-time measurements.
    pub wall: WallInfo,
    /// With a real transport (`--transport processes|tcp`): bytes and
    /// messages measured at the transport beside the virtual model's
    /// prediction for the same frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transport: Option<crate::cluster::remote::TransportSection>,
}

/// What [`build`] needs.
pub struct Inputs<'a> {
    /// The configuration.
    pub cfg: &'a ClusterConfig,
    /// The scene.
    pub input: &'a RenderInput,
    /// Per node, from the actors.
    pub nodes: Vec<NodeRaw>,
    /// The manager's stats.
    pub manager: ManagerStats,
    /// End of phase 1.
    pub phase1_end_s: f64,
    /// Per rank, when it stopped in phase 1.
    pub stopped_at: Vec<Option<f64>>,
    /// Phase-1 timeline.
    pub trace1: &'a SimTrace,
    /// Phase-1 traffic.
    pub traffic1: &'a TrafficStats,
    /// Phase 2.
    pub phase2: &'a Phase2,
    /// References.
    pub refs: Option<References>,
    /// Host seconds, phase 1.
    pub host_phase1_s: f64,
    /// Host seconds, phase 2.
    pub host_phase2_s: f64,
}

/// The one-time cost of replicated data ([`crate::node::replica`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Replication {
    /// Bytes of mesh each node holds (`V · 28 + C · 16`).
    pub node_bytes: u64,
    /// Bytes sent to put the whole mesh on every node (one work unit each).
    pub distribution_bytes: u64,
    /// Seconds of that on the network model if one host sends the units in
    /// turn (each waits for the previous one's arrival): once per dataset,
    /// like the transports' cell cache, not per frame.
    pub distribution_s: f64,
}

impl Replication {
    /// The cost for `n` nodes on `model`.
    pub fn new(input: &RenderInput, n: usize, model: &crate::net::NetworkModel) -> Replication {
        let r = crate::node::Replica::new(input.mesh.clone(), &[]);
        let unit = r.unit_bytes();
        Replication {
            node_bytes: r.node_bytes(),
            distribution_bytes: r.distribution_bytes(n),
            distribution_s: n as f64 * model.uncontended_arrival(0.0, unit),
        }
    }
}

/// Per rank (nodes, then the manager at index `n`, then its shards up to
/// index `n` of `ranks`), per kind, total seconds of distinct spans (the
/// thread driver records one span per compute action of a handler, all
/// equal); and each rank's end of its last scan span.
fn wall_busy(trace: &SimTrace, ranks: usize) -> (Vec<f64>, Vec<BTreeMap<TraceKind, f64>>) {
    let n = ranks - 1;
    let mut last_scan = vec![0.0f64; n + 1];
    let mut busy = vec![BTreeMap::new(); n + 1];
    let mut prev: Vec<Option<(f64, f64, TraceKind)>> = vec![None; n + 1];
    for e in &trace.events {
        let k = e.node.index();
        if k > n || matches!(e.kind, TraceKind::Send | TraceKind::Recv | TraceKind::Idle) {
            continue;
        }
        if prev[k] == Some((e.start, e.end, e.kind)) {
            continue;
        }
        prev[k] = Some((e.start, e.end, e.kind));
        *busy[k].entry(e.kind).or_insert(0.0) += e.end - e.start;
        if e.kind == TraceKind::Scan {
            last_scan[k] = last_scan[k].max(e.end);
        }
    }
    (last_scan, busy)
}

/// ERT exchange times of nodes `0..n` with the manager (rank `n`) and its
/// shards (ranks `n + 1 .. n + shards`).
fn t_share(trace: &SimTrace, n: usize, shards: usize) -> TShare {
    let pairs = n * shards;
    let mut sends: Vec<Vec<f64>> = vec![Vec::new(); pairs];
    let mut replies: Vec<Vec<f64>> = vec![Vec::new(); pairs];
    for e in &trace.events {
        let k = e.node.index();
        let Some(s) = e.peer.and_then(|p| p.index().checked_sub(n)) else {
            continue;
        };
        if k >= n || s >= shards {
            continue;
        }
        match (e.kind, e.message) {
            (TraceKind::Send, Some(MessageKind::ErtShare)) => sends[k * shards + s].push(e.start),
            (TraceKind::Recv, Some(MessageKind::ErtReply)) => replies[k * shards + s].push(e.end),
            _ => {}
        }
    }
    let mut all = Vec::new();
    for p in 0..pairs {
        // FIFO per pair: the i-th reply answers the i-th share.
        for (s, r) in sends[p].iter().zip(&replies[p]) {
            all.push(r - s);
        }
    }
    let m = all.len();
    TShare {
        exchanges: m,
        mean_s: if m > 0 {
            all.iter().sum::<f64>() / m as f64
        } else {
            0.0
        },
        max_s: all.iter().copied().fold(0.0, f64::max),
        per_exchange_s: if m <= 20_000 { all } else { Vec::new() },
    }
}

/// Builds the report.
pub fn build(i: Inputs) -> ClusterReport {
    let cfg = i.cfg;
    let p1 = &cfg.phase1;
    let n = i.nodes.len();
    let wall = p1.clock == ClockKind::Wall;
    let shards = i.manager.shards.max(1);
    let (wall_tsc, wall_busy) = if wall {
        wall_busy(i.trace1, n + shards)
    } else {
        (Vec::new(), Vec::new())
    };
    let nodes: Vec<NodeReport> = i
        .nodes
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let s = &r.stats;
            let (tsc, scan, share, steal) = if wall {
                let b = &wall_busy[k];
                let g = |t| b.get(&t).copied().unwrap_or(0.0);
                (
                    wall_tsc[k],
                    g(TraceKind::Scan),
                    g(TraceKind::Share),
                    g(TraceKind::Steal),
                )
            } else {
                (s.tsc_s, s.scan_s, s.share_s, s.steal_s)
            };
            NodeReport {
                rank: k,
                tsc_s: tsc,
                scan_s: scan,
                update_s: if wall { 0.0 } else { s.update_s },
                share_s: share,
                steal_s: steal,
                idle_s: (i.phase1_end_s - scan - share - steal).max(0.0),
                composite_s: (!wall).then(|| i.phase2.busy_s[k]),
                cells_initial: s.cells_initial,
                cells_processed: r.processed,
                cells_skipped_ert: r.skipped,
                cells_culled: r.culled,
                cells_given: s.cells_given,
                cells_taken: s.cells_taken,
                shares_sent: s.shares_sent,
                requests_sent: s.requests_sent,
                bytes_sent: s.bytes_sent + i.phase2.bytes_sent[k],
                bytes_sent_phase1: s.bytes_sent,
                segments_stored: r.stored,
            }
        })
        .collect();
    let tsc: Vec<f64> = nodes.iter().map(|x| x.tsc_s).collect();
    let tsc_max = tsc.iter().copied().fold(0.0, f64::max);
    let tsc_min = tsc.iter().copied().fold(f64::INFINITY, f64::min);
    let tsc_mean = tsc.iter().sum::<f64>() / n.max(1) as f64;
    let mut traffic = i.traffic1.clone();
    traffic.merge(&i.phase2.sim.traffic);
    let bytes_by_kind = traffic
        .sent_by_kind
        .iter()
        .map(|(k, c)| (k.name().to_string(), c.bytes))
        .collect();
    let messages_by_kind = traffic
        .sent_by_kind
        .iter()
        .map(|(k, c)| (k.name().to_string(), c.messages))
        .collect();
    let composite_s = if wall {
        i.host_phase2_s
    } else {
        i.phase2.sim.end_time
    };
    let skipped: u64 = nodes.iter().map(|x| x.cells_skipped_ert).sum();
    let ert_on = p1.node.ert.enabled();
    let refs = i.refs;
    let seq_s = refs.map(|r| r.seq_s);
    let base = refs.map(|r| r.base_tsc_max_s.unwrap_or(tsc_max));
    let speedup = seq_s.filter(|_| tsc_max > 0.0).map(|s| s / tsc_max);
    let frame_s = i.phase1_end_s + composite_s;
    let speedup_frame = seq_s.filter(|_| frame_s > 0.0).map(|s| s / frame_s);
    let manager_busy_s = if wall {
        wall_busy
            .get(n)
            .map_or(0.0, |b| b.values().sum::<f64>().max(0.0))
    } else {
        i.manager.busy_s
    };
    let mut manager = i.manager;
    if wall {
        // Per shard from its spans, as for the manager.
        manager.shard_busy_s = (n..n + shards)
            .map(|k| {
                wall_busy
                    .get(k)
                    .map_or(0.0, |b| b.values().sum::<f64>().max(0.0))
            })
            .collect();
    }
    let shard_busy_max_s = manager
        .shard_busy_s
        .iter()
        .copied()
        .fold(manager_busy_s, f64::max);
    let modelled_name = |name: &str| {
        if wall {
            "n/a (wall clock)".to_string()
        } else {
            name.to_string()
        }
    };
    ClusterReport {
        image: [i.input.scene.image.width, i.input.scene.image.height],
        cells_total: i.input.mesh.tets.len() as u64,
        n_nodes: n,
        clock: p1.clock,
        network: modelled_name(&cfg.network_name),
        profile: modelled_name(&cfg.profile_name),
        placement: clap::ValueEnum::to_possible_value(&cfg.placement)
            .map(|v| v.get_name().to_string())
            .unwrap_or_default(),
        compositor: cfg.compositor.clone(),
        codec: cfg.codec.clone(),
        ert_threshold: p1.node.ert.threshold,
        ert_table: p1.node.ert.divisions,
        ert_update: p1.node.ert.update_c,
        share: (p1.share || p1.overlap) && ert_on,
        sharing: if !ert_on {
            "off"
        } else if p1.share {
            "manager"
        } else if p1.overlap {
            "overlap"
        } else {
            "off"
        }
        .to_string(),
        share_levels: p1.node.ert.share_levels,
        share_sub: p1.node.ert.share_sub,
        share_window: p1.policy.share_window,
        ert_structure: match p1.node.ert.structure {
            crate::render::cell::ert::ErtStructure::Pyramid => "pyramid",
            crate::render::cell::ert::ErtStructure::Flat => "flat",
        }
        .to_string(),
        help_gap: p1.policy.help_gap,
        help_forwards: manager.help_forwards,
        data: p1.data,
        replication: (p1.data == crate::node::DataMode::Replicated)
            .then(|| Replication::new(i.input, n, &cfg.network)),
        dlb: p1.dlb,
        canonical: p1.node.canonical,
        frame_s,
        phase1_s: i.phase1_end_s,
        tsc_max_s: tsc_max,
        tsc_mean_s: tsc_mean,
        tsc_min_s: if n > 0 { tsc_min } else { 0.0 },
        imbalance: if tsc_mean > 0.0 {
            tsc_max / tsc_mean - 1.0
        } else {
            0.0
        },
        share_s_total: nodes.iter().map(|x| x.share_s).sum(),
        steal_s_total: nodes.iter().map(|x| x.steal_s).sum(),
        idle_s_total: nodes.iter().map(|x| x.idle_s).sum(),
        composite_s,
        bytes_total: traffic.total_sent().bytes,
        bytes_by_kind,
        messages_by_kind,
        t_share: t_share(i.trace1, n, shards),
        manager_busy_s,
        manager_shards: shards,
        shard_busy_max_s,
        manager,
        segments_stored: nodes.iter().map(|x| x.segments_stored).sum(),
        cells_processed: nodes.iter().map(|x| x.cells_processed).sum(),
        cells_skipped_ert: skipped,
        cells_moved: nodes.iter().map(|x| x.cells_taken).sum(),
        schedule_waves: super::phase1::effective_waves(p1, i.input.mesh.tets.len()),
        schedule_leaf_cells: p1.schedule_leaf_cells,
        schedule_stacking: i
            .nodes
            .first()
            .filter(|a| a.stats.schedule_keyed > 0)
            .map(|a| a.stats.schedule_stacking),
        schedule_applied: i.nodes.iter().any(|a| a.stats.schedule_applied),
        cells_scheduled: i.nodes.iter().map(|a| a.stats.cells_scheduled_in).sum(),
        sequential_s: seq_s,
        sequential_skipped: refs.map(|r| r.seq_skipped),
        base_tsc_max_s: base,
        share_efficiency: refs
            .filter(|r| ert_on && r.seq_skipped > 0)
            .map(|r| skipped as f64 / r.seq_skipped as f64),
        ideal_speedup: match (base, seq_s) {
            (Some(b), Some(s)) if s > 0.0 => Some(b / (s / n as f64)),
            _ => None,
        },
        speedup,
        efficiency: speedup.map(|s| s / n as f64),
        speedup_frame,
        efficiency_frame: speedup_frame.map(|s| s / n as f64),
        compositing: i.phase2.stats.clone(),
        nodes,
        wall: WallInfo {
            host_phase1_s: i.host_phase1_s,
            host_phase2_s: i.host_phase2_s,
        },
        transport: None,
    }
}

/// The summary printed at the end of `pvrsim cluster`: one line per node
/// (at most 32, then totals only), the totals, the speed-ups (frame-based
/// and Tsc-based side by side) and what the terms mean. One clock per
/// report: the header says which.
pub fn summary(r: &ClusterReport) -> String {
    use std::fmt::Write;
    let wall = r.clock == ClockKind::Wall;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "cluster: {} + manager, {}, ERT {}{}{}, {} / {}",
        crate::cli::plural(r.n_nodes, "node"),
        if wall {
            "wall clock (times measured on this host; no network or cost model)".to_string()
        } else {
            format!(
                "virtual clock (modelled times: network {}, profile {})",
                r.network, r.profile
            )
        },
        if r.ert_threshold < 1.0 {
            format!("{}", r.ert_threshold)
        } else {
            "off".into()
        },
        if r.share { " +SHARE" } else { "" },
        if r.dlb { " +DLB" } else { "" },
        r.compositor,
        r.codec
    );
    let _ = writeln!(
        s,
        "{:>5} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>7} {:>7} {:>11}",
        "node",
        "Tsc s",
        "scan s",
        "share s",
        "steal s",
        "idle s",
        "initial",
        "culled",
        "done",
        "skipped",
        "given",
        "taken",
        "bytes sent"
    );
    for x in r.nodes.iter().take(32) {
        let _ = writeln!(
            s,
            "{:>5} {:>9.4} {:>9.4} {:>8.4} {:>8.4} {:>8.4} {:>8} {:>8} {:>8} {:>8} {:>7} {:>7} {:>11}",
            x.rank,
            x.tsc_s,
            x.scan_s,
            x.share_s,
            x.steal_s,
            x.idle_s,
            x.cells_initial,
            x.cells_culled,
            x.cells_processed,
            x.cells_skipped_ert,
            x.cells_given,
            x.cells_taken,
            x.bytes_sent
        );
    }
    if r.nodes.len() > 32 {
        let _ = writeln!(s, "  ... ({} more nodes in the report)", r.nodes.len() - 32);
    }
    let _ = writeln!(
        s,
        "Tsc max {:.4} s, mean {:.4} s, imbalance {:.1} %; phase 1 {:.4} s, phase 2 {:.4} s{}, frame {:.4} s",
        r.tsc_max_s,
        r.tsc_mean_s,
        100.0 * r.imbalance,
        r.phase1_s,
        r.composite_s,
        if r.transport.is_some() {
            " (wall clock, worker to worker)"
        } else if wall {
            " (host, all nodes on one thread)"
        } else {
            ""
        },
        r.frame_s
    );
    let culled: u64 = r.nodes.iter().map(|x| x.cells_culled).sum();
    let _ = writeln!(
        s,
        "cells: {} culled on arrival (empty or off screen), {} processed, {} skipped by ERT, {} moved by DLB; ERT exchanges {} (T_share mean {:.2} ms, max {:.2} ms); manager busy {:.4} s",
        culled,
        r.cells_processed,
        r.cells_skipped_ert,
        r.cells_moved,
        r.t_share.exchanges,
        1e3 * r.t_share.mean_s,
        1e3 * r.t_share.max_s,
        r.manager_busy_s
    );
    if let Some(st) = r.schedule_stacking {
        let _ = writeln!(
            s,
            "schedule: {} waves of leaves of {} cells, computed on every node (no byte travels); parts stacked {:.2} along the view: {}",
            r.schedule_waves,
            r.schedule_leaf_cells,
            st,
            if r.schedule_applied {
                format!("applied, {} cells dealt to another node than their placement part's", r.cells_scheduled)
            } else {
                "not applied (below the threshold), each node scans its part".to_string()
            }
        );
    }
    if r.manager_shards > 1 {
        let total: f64 = r.manager.shard_busy_s.iter().sum();
        let _ = writeln!(
            s,
            "manager shards: {} (shard 0 is the manager; the others run on their own PCs): busiest {:.4} s, all {:.4} s, shares per shard {:?}",
            r.manager_shards, r.shard_busy_max_s, total, r.manager.shard_shares
        );
    }
    let kinds: Vec<String> = r
        .bytes_by_kind
        .iter()
        .map(|(k, b)| format!("{k} {b}"))
        .collect();
    let _ = writeln!(s, "bytes: {} total ({})", r.bytes_total, kinds.join(", "));
    match (r.sequential_s, r.speedup, r.speedup_frame) {
        (Some(seq), Some(sp), Some(spf)) => {
            let _ = writeln!(
                s,
                "sequential (one node, every cell, same ERT, same clock) {seq:.4} s; speed-up: frame-based {spf:.2} (efficiency {:.3}), Tsc-based {sp:.2} (efficiency {:.3})",
                spf / r.n_nodes as f64,
                sp / r.n_nodes as f64
            );
        }
        _ => {
            let _ = writeln!(s, "no reference runs (--no-baselines): no speed-ups");
        }
    }
    let opt = |v: Option<f64>, d: usize| v.map_or("n/a".to_string(), |v| format!("{v:.d$}"));
    if let Some(rp) = &r.replication {
        let _ = writeln!(
            s,
            "data: replicated (DLB and help move cell ids): the mesh takes {:.1} MB on every node; putting it there once per dataset sends {:.1} MB ({:.2} s from one host on {}), not part of any frame",
            rp.node_bytes as f64 / 1e6,
            rp.distribution_bytes as f64 / 1e6,
            rp.distribution_s,
            r.network
        );
    } else {
        let _ = writeln!(
            s,
            "data: partitioned (DLB and help move cells with their vertices)"
        );
    }
    if let Some(b) = r.base_tsc_max_s {
        let _ = writeln!(
            s,
            "Base Tsc max {b:.4} s; ideal speed-up {}, share efficiency {}",
            opt(r.ideal_speedup, 2),
            opt(r.share_efficiency, 3)
        );
    }
    let _ = writeln!(
        s,
        "terms: Tsc = a node's scan-conversion time (phase 1, no compositing); frame = phase 1 + phase 2; speed-up = sequential / frame or / Tsc max; Base = ERT, sharing and DLB off at the same N; ideal speed-up = Base Tsc max / (sequential / N); share efficiency = cells skipped by all nodes / cells skipped by the sequential run"
    );
    s
}
