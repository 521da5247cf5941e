//! Measured beside modelled: the bytes and messages per kind the TCP
//! transport carried in phase 1, next to what the virtual-clock model sends
//! for the same frame (same scene, nodes, options; the `--network` model).
//!
//! Payload bytes are the application's bytes, as the simulator counts them;
//! wire bytes add the 18-byte link frame per message (tag + header),
//! heartbeats and goodbyes. Without sharing and DLB the phase-1 protocol is
//! deterministic, so the counts must agree exactly; with them, the number
//! of shares and grants depends on timing.
//!
//! Phase 2 runs worker to worker ([`super::phase2`]): its `Segments` and
//! `Image` messages as the workers' transports counted them, beside the
//! model's replay of the same frame's compositing. A measured message
//! carries a 21-byte header the model does not have, and the root hands its
//! own pixels to the coordinator (the model's schedule ends at the root);
//! both are subtracted before the comparison (`phase2_bytes_match`).

use std::collections::BTreeMap;

use super::measured::Measured;
use crate::cluster::{phase1, ClockKind, ClusterConfig, ClusterOutcome};
use crate::net::{Codec, Counter, MessageKind};
use crate::node::Placement;
use crate::render::RenderInput;

pub use crate::cluster::report::transport::{
    KindLine, Phase1Model, Phase2Rank, RecoveryModel, TransportSection,
};

/// The frame on the virtual clock with `placement`: phase 1, and phase 2
/// replayed on the network model.
fn model(
    input: &RenderInput,
    cfg: &ClusterConfig,
    placement: &Placement,
    p1: crate::cluster::Phase1Config,
) -> anyhow::Result<(phase1::Phase1, crate::cluster::phase2::Phase2)> {
    let codec = Codec::default();
    let nodes = phase1::build_nodes(input, placement, &p1, &cfg.profile, codec)?;
    let sim = phase1::run(nodes, &p1, &cfg.network, &cfg.profile, codec)?;
    let model2 = {
        let strategy = cfg.compositor.build();
        let list_codec = cfg.codec.build();
        let lists = sim
            .nodes
            .iter()
            .map(|a| crate::cluster::node_lists(a.renderer(), input, p1.node))
            .collect();
        crate::cluster::phase2::run(
            strategy.as_ref(),
            list_codec.as_ref(),
            lists,
            super::phase2::exec_options(p1.node.partial_composition, &input.scene),
            &cfg.profile,
            &cfg.network,
            false,
        )?
    };
    Ok((sim, model2))
}

impl PartialEq for Measured {
    fn eq(&self, o: &Measured) -> bool {
        self.phase1 == o.phase1 && self.cells_bytes_sent == o.cells_bytes_sent
    }
}

/// Runs phase 1 of the same frame on the virtual clock and lays its
/// traffic beside the measured one.
pub fn transport_section(
    input: &RenderInput,
    cfg: &ClusterConfig,
    out: &ClusterOutcome,
    m: Measured,
) -> anyhow::Result<TransportSection> {
    let mut p1 = cfg.phase1;
    p1.clock = ClockKind::Virtual;
    p1.record_trace = false;
    // After `--on-failure reassign`, the model runs the placement that
    // completed, on the survivors.
    let placement = match &m.reassigned {
        Some(r) => {
            p1.nodes = r.parts.len();
            Placement {
                parts: r.parts.clone(),
            }
        }
        None => crate::cluster::place_on(input, cfg.placement, p1.nodes),
    };
    let (sim, model2) = model(input, cfg, &placement, p1)?;
    // The recovery's modelled cost: the survivors' frame beside the
    // undisturbed one on every worker, plus the work the loss threw away.
    let recovery = match &m.reassigned {
        None => None,
        Some(r) => {
            let mut q1 = p1;
            q1.nodes = r.parts.len() + r.lost.len();
            let all = crate::cluster::place_on(input, cfg.placement, q1.nodes);
            let (s0, m0) = model(input, cfg, &all, q1)?;
            let undisturbed = s0.end_s + m0.sim.end_time;
            let lost_work: f64 = r
                .events
                .iter()
                .map(|e| match e.phase.as_str() {
                    "phase 1" | "collecting results" => s0.end_s,
                    "phase 2" => undisturbed,
                    _ => 0.0,
                })
                .sum();
            let survivors = sim.end_s + model2.sim.end_time;
            Some(RecoveryModel {
                undisturbed_s: undisturbed,
                survivors_s: survivors,
                lost_work_s: lost_work,
                recovery_s: survivors - undisturbed + lost_work,
                measured_s: r.recovery_s,
            })
        }
    };
    let mut by_kind2: BTreeMap<String, KindLine> = BTreeMap::new();
    let mut msgs2 = 0;
    for (k, c) in &m.phase2.payload.sent_by_kind {
        if matches!(k, MessageKind::Segments | MessageKind::Image) {
            by_kind2.entry(k.name().to_string()).or_default().measured = *c;
            msgs2 += c.messages;
        }
    }
    for (k, c) in &model2.sim.traffic.sent_by_kind {
        by_kind2.entry(k.name().to_string()).or_default().modelled = *c;
    }
    let header = msgs2 * super::phase2::HEADER_BYTES as u64;
    let handoff = Counter {
        messages: m.phase2_handoff_messages,
        bytes: m.phase2_handoff_bytes
            + m.phase2_handoff_messages * super::phase2::HEADER_BYTES as u64,
    };
    let phase2_bytes_match = by_kind2.iter().all(|(k, l)| {
        let mut c = l.measured;
        let hdr = c.messages * super::phase2::HEADER_BYTES as u64;
        c.bytes = c.bytes.saturating_sub(hdr);
        if k.as_str() == MessageKind::Image.name() {
            c.messages = c.messages.saturating_sub(m.phase2_handoff_messages);
            c.bytes = c.bytes.saturating_sub(m.phase2_handoff_bytes);
        }
        c == l.modelled
    });
    let mut by_kind: BTreeMap<String, KindLine> = BTreeMap::new();
    for (k, c) in &m.phase1.payload.sent_by_kind {
        by_kind.entry(k.name().to_string()).or_default().measured = *c;
    }
    for (k, c) in &sim.traffic.sent_by_kind {
        by_kind.entry(k.name().to_string()).or_default().modelled = *c;
    }
    Ok(TransportSection {
        phase1_bytes_match: by_kind.values().all(|l| l.measured == l.modelled),
        phase1_by_kind: by_kind,
        phase1_wire_bytes: m.phase1.wire_bytes_sent,
        phase1_heartbeats: m.phase1.heartbeats_sent,
        phase1_measured_s: out.report.phase1_s,
        phase1_modelled_s: sim.end_s,
        setup_cells_bytes: m.cells_bytes_sent,
        setup_cells_cached: m.cells_cached,
        setup_s: m.setup_s,
        collect_s: m.collect_s,
        reassigned: m.reassigned.clone(),
        recovery,
        phase2_by_kind: by_kind2,
        phase2_header_bytes: header,
        phase2_handoff: handoff,
        phase2_bytes_match,
        phase2_wire_bytes: m.phase2.wire_bytes_sent,
        phase2_measured_s: m.phase2_s,
        phase2_modelled_s: model2.sim.end_time,
        phase2_ranks: m
            .phase2_ranks
            .iter()
            .enumerate()
            .map(|(k, r)| Phase2Rank {
                wall_s: r.wall_s,
                cpu_s: r.cpu_s,
                compress_s: r.compress_s,
                modelled_compute_s: model2.busy_s.get(k).copied().unwrap_or(0.0),
            })
            .collect(),
        phase1_modelled_nodes: sim
            .nodes
            .iter()
            .enumerate()
            .map(|(k, a)| {
                let s = a.stats();
                Phase1Model {
                    scan_s: s.scan_s,
                    share_s: s.share_s,
                    steal_s: s.steal_s,
                    tsc_s: s.tsc_s,
                    end_s: sim.stopped_at.get(k).copied().flatten().unwrap_or(s.tsc_s),
                }
            })
            .collect(),
    })
}
