//! What a real transport measured beside the report ([`Measured`]): the
//! coordinator ([`super::coordinator`]), the transport-independent driver
//! ([`super::drive`]) and MPI fill it, [`super::compare`] reads it.

use super::reassign::Reassigned;
use crate::net::tcp::WireStats;

/// What the transport measured, beside the report.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Measured {
    /// Phase 1, all ranks: bytes on the wire and payload per kind.
    pub phase1: WireStats,
    /// Set-up: bytes of cells sent (0 when every worker had them cached).
    pub cells_bytes_sent: u64,
    /// Workers that had their cells cached.
    pub cells_cached: usize,
    /// Seconds to connect, set up and mesh.
    pub setup_s: f64,
    /// Seconds to collect the results.
    pub collect_s: f64,
    /// Phase 2, all workers: bytes on the wire and payload per kind, as
    /// their transports counted them (lists worker to worker, pixels to the
    /// coordinator).
    pub phase2: WireStats,
    /// Codec bytes of the root's own pixels handed to the coordinator (not
    /// a message of the schedule, which ends at the root).
    pub phase2_handoff_bytes: u64,
    /// Messages of that hand-off.
    pub phase2_handoff_messages: u64,
    /// Seconds from the start of phase 2 to the last pixels in.
    pub phase2_s: f64,
    /// Per worker (rank order): its phase-2 wall and thread CPU seconds
    /// (from its log).
    pub phase2_ranks: Vec<(f64, f64)>,
    /// Set when `--on-failure reassign` re-ran the frame on survivors.
    pub reassigned: Option<Reassigned>,
}

impl Measured {
    /// Every byte of the frame the transport wrote: both phases' wire
    /// bytes (frames, heartbeats, goodbyes), the root's hand-off and the
    /// cells sent at set-up.
    pub fn frame_bytes(&self) -> u64 {
        self.phase1.wire_bytes_sent
            + self.phase2.wire_bytes_sent
            + self.phase2_handoff_bytes
            + self.cells_bytes_sent
    }
}
