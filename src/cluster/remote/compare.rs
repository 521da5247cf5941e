//! Measured beside modelled: the bytes and messages per kind the TCP
//! transport carried in phase 1, next to what the virtual-clock model sends
//! for the same frame (same scene, nodes, options; the `--network` model).
//!
//! Payload bytes are the application's bytes, as the simulator counts them;
//! wire bytes add the 18-byte link frame per message (tag + header),
//! heartbeats and goodbyes. Without sharing and DLB the phase-1 protocol is
//! deterministic, so the counts must agree exactly; with them, the number
//! of shares and grants depends on timing.

use std::collections::BTreeMap;

use serde::Serialize;

use super::coordinator::Measured;
use crate::cluster::{phase1, ClockKind, ClusterConfig, ClusterOutcome};
use crate::net::{Codec, Counter};
use crate::node::Placement;
use crate::render::RenderInput;

/// Bytes and messages of one kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct KindLine {
    /// Measured at the transport: messages, payload bytes.
    pub measured: Counter,
    /// The virtual model's run of the same frame.
    pub modelled: Counter,
}

/// The `transport` section of the report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransportSection {
    /// Phase 1 per message kind (`MessageKind::name`), sent by all ranks.
    pub phase1_by_kind: BTreeMap<String, KindLine>,
    /// True when every kind's measured messages and bytes equal the model's.
    pub phase1_bytes_match: bool,
    /// Bytes written on the wire in phase 1 (frames, heartbeats, goodbyes).
    pub phase1_wire_bytes: u64,
    /// Heartbeats written in phase 1.
    pub phase1_heartbeats: u64,
    /// Measured phase-1 wall seconds (end of the last node).
    pub phase1_measured_s: f64,
    /// Modelled phase-1 seconds (virtual clock, `--network` model and cost profile).
    pub phase1_modelled_s: f64,
    /// Bytes of cells sent at set-up (0 if every worker had them cached).
    pub setup_cells_bytes: u64,
    /// Workers that had the cells cached.
    pub setup_cells_cached: usize,
    /// Seconds of connection, set-up and mesh.
    pub setup_s: f64,
    /// Bytes of the nodes' lists gathered by the coordinator.
    pub lists_gathered_bytes: u64,
    /// Seconds to gather them.
    pub gather_s: f64,
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
    let codec = Codec::default();
    let placement = Placement::new(
        &input.mesh,
        p1.nodes,
        cfg.placement,
        Some(&input.scene.view()),
    );
    let nodes = phase1::build_nodes(input, &placement, &p1, &cfg.profile, codec)?;
    let sim = phase1::run(nodes, &p1, &cfg.network, &cfg.profile, codec)?;
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
        lists_gathered_bytes: m.lists_bytes,
        gather_s: m.collect_s,
    })
}
