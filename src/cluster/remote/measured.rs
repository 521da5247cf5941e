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
    /// Per worker (rank order): its phase-2 times (from its log).
    pub phase2_ranks: Vec<RankTimes>,
    /// Set when `--on-failure reassign` re-ran the frame on survivors.
    pub reassigned: Option<Reassigned>,
}

/// One worker's phase-2 times, as its log gives them.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct RankTimes {
    /// Wall seconds from its start of phase 2 to its last send.
    pub wall_s: f64,
    /// Thread CPU seconds of the same span.
    pub cpu_s: f64,
    /// Wall seconds of it spent encoding with the codec (compress).
    pub compress_s: f64,
}

impl Measured {
    /// The slowest worker's compress seconds of the frame (IceT's per
    /// frame compress time, the critical path's), `None` without workers.
    pub fn compress_s(&self) -> Option<f64> {
        self.phase2_ranks
            .iter()
            .map(|r| r.compress_s)
            .reduce(f64::max)
    }

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
