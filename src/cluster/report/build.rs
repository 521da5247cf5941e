//! Computes a [`ClusterReport`] from a run's pieces ([`Inputs`]): per-node
//! lines, totals, traffic by kind, ERT exchange times and the ratios
//! against the reference runs.

use std::collections::BTreeMap;

use super::types::{ClusterReport, NodeRaw, NodeReport, References, Replication, TShare, WallInfo};
use crate::cluster::phase2::Phase2;
use crate::cluster::FrameData;
use crate::cluster::{ClockKind, ClusterConfig};
use crate::manager::ManagerStats;
use crate::net::{MessageKind, SimTrace, TraceKind, TrafficStats};

/// What [`build`] needs.
pub struct Inputs<'a> {
    /// The configuration.
    pub cfg: &'a ClusterConfig,
    /// The scene and its data.
    pub data: FrameData<'a>,
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
                peak_rss_bytes: r.peak_rss_bytes,
                modelled_bytes: r.vertices_initial.map(|v| {
                    v * 28 + s.cells_initial * 16 + s.cells_taken * (16 + 4 * 28) + r.stored * 24
                }),
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
        image: [i.data.scene().image.width, i.data.scene().image.height],
        cells_total: i.data.cells_total(),
        n_nodes: n,
        clock: p1.clock,
        network: modelled_name(&cfg.network_name),
        profile: modelled_name(&cfg.profile_name),
        placement: clap::ValueEnum::to_possible_value(&cfg.placement)
            .map(|v| v.get_name().to_string())
            .unwrap_or_default(),
        compositor: cfg.compositor.to_string(),
        codec: cfg.codec.to_string(),
        ert_threshold: p1.node.ert.threshold(),
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
        replication: match i.data {
            FrameData::Mesh(input) if p1.data == crate::node::DataMode::Replicated => {
                Some(Replication::new(input, n, &cfg.network))
            }
            _ => None,
        },
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
        schedule_waves: crate::cluster::phase1::effective_waves(
            p1,
            usize::try_from(i.data.cells_total()).unwrap_or(usize::MAX),
        ),
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
        coordinator_peak_rss_bytes: i
            .nodes
            .iter()
            .any(|r| r.peak_rss_bytes.is_some())
            .then(crate::net::cpu::peak_rss_bytes)
            .flatten(),
        nodes,
        wall: WallInfo {
            host_phase1_s: i.host_phase1_s,
            host_phase2_s: i.host_phase2_s,
        },
        transport: None,
        pieces: None,
        cpu: super::cpu::cpu_section(i.trace1, &i.stopped_at),
        series: None,
    }
}
