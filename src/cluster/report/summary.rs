//! The human-readable summary of a [`ClusterReport`] printed at the end of
//! `pvrsim cluster`.

use super::types::ClusterReport;
use crate::cluster::ClockKind;

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
        crate::text::plural(r.n_nodes, "node"),
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
    if let Some(line) = memory_line(r) {
        let _ = writeln!(s, "{line}");
    }
    if let Some(p) = &r.pieces {
        let parts: Vec<String> = match &p.shares {
            Some(sh) => sh
                .iter()
                .map(|q| {
                    let one: Vec<String> = q
                        .iter()
                        .map(|x| format!("{} ({} of {})", x.piece, x.part + 1, x.of))
                        .collect();
                    format!("[{}]", one.join(", "))
                })
                .collect(),
            None => p.parts.iter().map(|q| format!("{q:?}")).collect(),
        };
        let _ = writeln!(
            s,
            "pieces: the {} pieces of {} read by the workers themselves (by rank: {}); the coordinator read {} vertices, no cells{}",
            p.pieces,
            p.pvtu,
            parts.join(" "),
            p.vertices_read_by_coordinator,
            match &p.reassigned {
                Some(re) => format!(
                    "; {} lost, their {} pieces read by the survivors",
                    re.lost.join(", "),
                    re.cells
                ),
                None => String::new(),
            }
        );
    }
    let _ = writeln!(
        s,
        "Tsc max {:.4} s, mean {:.4} s, imbalance {:.1} %; phase 1 {:.4} s, phase 2 {:.4} s{}, frame {:.4} s",
        r.tsc_max_s,
        r.tsc_mean_s,
        100.0 * r.imbalance,
        r.phase1_s,
        r.composite_s,
        if r.transport.is_some() || r.pieces.is_some() {
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
            "data: replicated (DLB and help move cell ids): the mesh takes {:.1} MB on every node; putting it there once per dataset sends {:.1} MB ({:.2} s from one host {}), not part of any frame",
            rp.node_bytes as f64 / 1e6,
            rp.distribution_bytes as f64 / 1e6,
            rp.distribution_s,
            if r.clock == crate::cluster::ClockKind::Wall {
                // No model times this run's frames; the figure is modelled.
                "by the network model; the wall clock does not time it".to_string()
            } else {
                format!("on {}", r.network)
            }
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

/// The memory line: measured with worker processes (the coordinator's and
/// every worker's peak resident memory), modelled when the driver knew the
/// placement (bytes of each node's part and lists), in MB.
fn memory_line(r: &ClusterReport) -> Option<String> {
    let mb = |b: u64| format!("{:.1}", b as f64 / 1e6);
    let per_node = |f: fn(&super::types::NodeReport) -> Option<u64>| {
        let v: Vec<String> = r
            .nodes
            .iter()
            .map(|x| f(x).map_or("n/a".to_string(), mb))
            .collect();
        v.join(", ")
    };
    if let Some(c) = r.coordinator_peak_rss_bytes {
        return Some(format!(
            "peak resident memory (MB, measured): coordinator {}; workers by rank [{}]",
            mb(c),
            per_node(|x| x.peak_rss_bytes)
        ));
    }
    r.nodes.iter().any(|x| x.modelled_bytes.is_some()).then(|| {
        format!(
            "memory per node (MB, modelled: part's vertices and cells, taken cells, lists): [{}]",
            per_node(|x| x.modelled_bytes)
        )
    })
}
