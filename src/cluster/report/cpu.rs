//! The report's `cpu` section (real transports): per rank and per activity,
//! the compute the cost model charged beside the wall and **thread CPU**
//! seconds the same calls took on this host ([`crate::net::cpu`]).
//!
//! CPU seconds are what a modelled compute cost is compared with: on a
//! host with fewer cores than ranks, a call's wall time also holds the time
//! its thread waited for a core. `wait_s` is the rest of the rank's phase-1
//! wall time: receiving, waiting for peers and the wire, waiting for a core.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::net::{SimTrace, TraceKind};

/// One activity of one rank.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct CpuLine {
    /// Handler calls (compute actions) of this activity.
    pub calls: u64,
    /// Modelled seconds (the cost profile the rank ran with).
    pub modelled_s: f64,
    /// Measured thread CPU seconds.
    pub cpu_s: f64,
    /// Measured wall seconds of the same calls.
    pub wall_s: f64,
}

/// One rank's phase 1 on a real transport.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CpuRank {
    /// Rank (nodes first, then the manager and its shards).
    pub rank: usize,
    /// Per activity (`scan`, `share`, `steal`, `composite`, `compute`).
    pub by_activity: BTreeMap<String, CpuLine>,
    /// Phase-1 wall seconds: when the rank stopped.
    pub phase1_wall_s: f64,
    /// Phase-1 thread CPU seconds in compute calls (all activities).
    pub phase1_cpu_s: f64,
    /// Phase-1 modelled compute seconds (all activities).
    pub phase1_modelled_s: f64,
    /// `phase1_wall_s − phase1_cpu_s`: messages, waiting for peers and the
    /// wire, and for a core.
    pub wait_s: f64,
}

/// Builds the section from the phase-1 trace's CPU samples (`None` when
/// there are none: the virtual clock, or `--clock wall` with sleeping).
pub fn cpu_section(trace: &SimTrace, stopped_at: &[Option<f64>]) -> Option<Vec<CpuRank>> {
    if trace.cpu.is_empty() {
        return None;
    }
    let ranks = trace
        .cpu
        .iter()
        .map(|s| s.node.index() + 1)
        .max()
        .unwrap_or(0)
        .max(stopped_at.len());
    let mut out: Vec<CpuRank> = (0..ranks)
        .map(|rank| CpuRank {
            rank,
            by_activity: BTreeMap::new(),
            phase1_wall_s: stopped_at.get(rank).copied().flatten().unwrap_or(0.0),
            phase1_cpu_s: 0.0,
            phase1_modelled_s: 0.0,
            wait_s: 0.0,
        })
        .collect();
    for s in &trace.cpu {
        let r = &mut out[s.node.index()];
        let l = r
            .by_activity
            .entry(activity_name(s.kind).to_string())
            .or_default();
        l.calls += 1;
        l.modelled_s += s.modelled_s;
        l.cpu_s += s.cpu_s;
        l.wall_s += s.wall_s;
        r.phase1_cpu_s += s.cpu_s;
        r.phase1_modelled_s += s.modelled_s;
    }
    for r in &mut out {
        r.wait_s = (r.phase1_wall_s - r.phase1_cpu_s).max(0.0);
    }
    Some(out)
}

/// The report's name of an activity.
pub fn activity_name(k: TraceKind) -> &'static str {
    k.name()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::net::cpu::CpuSample;
    use crate::net::NodeId;

    #[test]
    fn sums_per_rank_and_activity() {
        let mut t = SimTrace::default();
        let s = |node: u32, kind, m, c| CpuSample {
            node: NodeId(node),
            kind,
            start: 0.0,
            modelled_s: m,
            wall_s: 2.0 * c,
            cpu_s: c,
        };
        t.cpu = vec![
            s(0, TraceKind::Scan, 1.0, 0.5),
            s(0, TraceKind::Scan, 1.0, 0.25),
            s(1, TraceKind::Share, 0.1, 0.2),
        ];
        assert!(cpu_section(&SimTrace::default(), &[]).is_none());
        let c = cpu_section(&t, &[Some(1.0), Some(0.5), Some(0.6)]).unwrap();
        assert_eq!(c.len(), 3);
        let scan = c[0].by_activity["scan"];
        assert_eq!(scan.calls, 2);
        assert!((scan.cpu_s - 0.75).abs() < 1e-12 && (scan.wall_s - 1.5).abs() < 1e-12);
        assert!((c[0].wait_s - 0.25).abs() < 1e-12);
        assert!((c[1].phase1_modelled_s - 0.1).abs() < 1e-12);
        assert!(c[2].by_activity.is_empty());
    }
}
