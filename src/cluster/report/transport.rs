//! The `transport` section of a cluster report ([`TransportSection`]):
//! what a real transport measured beside the virtual model's run of the
//! same frame, and what `--on-failure reassign` did ([`Reassigned`]). The
//! types live here, below the transports that fill them
//! ([`crate::cluster::remote`] builds the section in `compare.rs`).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::net::Counter;

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
    /// Seconds to collect the nodes' results.
    pub collect_s: f64,
    /// Set when `--on-failure reassign` re-ran the frame on the survivors
    /// (the model then runs their placement).
    pub reassigned: Option<Reassigned>,
    /// With `reassigned`: the recovery's cost, modelled beside measured.
    pub recovery: Option<RecoveryModel>,
    /// Phase 2 (worker to worker) per message kind, sent by all workers.
    pub phase2_by_kind: BTreeMap<String, KindLine>,
    /// Of the measured phase-2 payload: message headers.
    pub phase2_header_bytes: u64,
    /// Of the measured phase-2 payload: the root's own pixels handed to the
    /// coordinator (messages, codec bytes).
    pub phase2_handoff: Counter,
    /// True when, without headers and the hand-off, every phase-2 kind's
    /// measured messages and bytes equal the model's.
    pub phase2_bytes_match: bool,
    /// Bytes written on the wire in phase 2 by the workers.
    pub phase2_wire_bytes: u64,
    /// Measured phase-2 wall seconds (coordinator: start to last pixels).
    pub phase2_measured_s: f64,
    /// Modelled phase-2 seconds (the replay on the `--network` model).
    pub phase2_modelled_s: f64,
    /// Per worker: its phase-2 time measured (wall, thread CPU) beside the
    /// model's compute for it.
    pub phase2_ranks: Vec<Phase2Rank>,
    /// Per node: the virtual-clock run's modelled phase-1 seconds
    /// (`scan`, `share`, `steal`, and `tsc`, its end of scanning).
    pub phase1_modelled_nodes: Vec<Phase1Model>,
}

/// One worker's phase 2, measured and modelled.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Phase2Rank {
    /// Measured wall seconds (its start of phase 2 to its last send).
    pub wall_s: f64,
    /// Measured thread CPU seconds of the same span.
    pub cpu_s: f64,
    /// Measured wall seconds of it encoding messages with the codec
    /// (IceT's compress time).
    pub compress_s: f64,
    /// Modelled compute seconds (merges, compositing, pasting).
    pub modelled_compute_s: f64,
}

/// One node's modelled phase 1 (virtual clock, same frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Phase1Model {
    /// Seconds scanning (chunks and ERT updates).
    pub scan_s: f64,
    /// Seconds applying shared tables.
    pub share_s: f64,
    /// Seconds packing and unpacking moved cells.
    pub steal_s: f64,
    /// End of its last scan chunk.
    pub tsc_s: f64,
    /// When it stopped (end of its phase 1).
    pub end_s: f64,
}

/// What a recovery (`--on-failure reassign`) cost, in the model (virtual
/// clock, `--network` model and cost profile) and measured. The model does
/// not include the time to notice a loss (immediate for a closed
/// connection, the heartbeat deadline for a stall); the measured figure
/// does.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RecoveryModel {
    /// Modelled frame (phase 1 + phase 2) on every worker, undisturbed.
    pub undisturbed_s: f64,
    /// Modelled frame on the survivors with the reassigned placement.
    pub survivors_s: f64,
    /// Modelled work thrown away by the losses: none at set-up, the
    /// undisturbed phase 1 for a loss in phase 1 or while collecting (an
    /// upper bound: the loss came part way), the whole frame in phase 2.
    pub lost_work_s: f64,
    /// `survivors_s - undisturbed_s + lost_work_s`.
    pub recovery_s: f64,
    /// Measured: wall seconds of the failed attempts (detection included).
    pub measured_s: f64,
}

/// One loss and what was done about it.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct LossEvent {
    /// The phase the frame was in.
    pub phase: String,
    /// The workers lost, by name.
    pub workers: Vec<String>,
    /// Cells (mesh frames) or bricks (grid frames) moved to the survivors.
    pub moved: u64,
    /// Survivors that took them.
    pub survivors: usize,
    /// Seconds from the start of the frame (the first attempt) until the
    /// loss was known and the retry began.
    pub detected_at_s: f64,
    /// Wall seconds of the failed attempt (from its start to the retry):
    /// the measured cost of the loss.
    pub attempt_s: f64,
    /// The error that ended the attempt.
    pub error: String,
}

/// What `--on-failure reassign` did.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Reassigned {
    /// The workers lost, by name.
    pub lost: Vec<String>,
    /// Their cells (or bricks), given to the survivors.
    pub cells: u64,
    /// The error that ended the first attempt.
    pub first_error: String,
    /// Every loss in order.
    pub events: Vec<LossEvent>,
    /// Measured recovery cost: wall seconds of the failed attempts.
    pub recovery_s: f64,
    /// The placement of the run that completed (survivors by new rank).
    #[serde(skip)]
    pub parts: Vec<Vec<u32>>,
}

/// The `pieces` section of a run whose workers read their own pieces of a
/// `.pvtu` ([`crate::cluster::remote::pieces`]): what was read where, and
/// what the transport measured (the virtual model's comparison needs the
/// cells in the coordinator, so there is no `transport` section).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PiecesSection {
    /// The `.pvtu` the workers read.
    pub pvtu: String,
    /// Its pieces.
    pub pieces: usize,
    /// Vertices the coordinator read of them (the field's and depth ranges).
    pub vertices_read_by_coordinator: u64,
    /// Per node of the run that completed, the pieces it read.
    pub parts: Vec<Vec<u32>>,
    /// With fewer pieces than nodes, per node the parts of split pieces it
    /// kept ([`crate::node::piece_map`]); absent when no piece is split.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shares: Option<Vec<Vec<crate::node::piece_map::Share>>>,
    /// Seconds of connection, set-up, reading the pieces and the mesh.
    pub setup_s: f64,
    /// Bytes written on the wire in phase 1 (frames, heartbeats, goodbyes).
    pub phase1_wire_bytes: u64,
    /// Bytes written on the wire in phase 2 by the workers.
    pub phase2_wire_bytes: u64,
    /// Set when `--on-failure reassign` re-ran the frame on the survivors
    /// (`cells` counts the pieces they took over).
    pub reassigned: Option<Reassigned>,
}
