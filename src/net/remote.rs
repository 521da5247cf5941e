//! [`RemoteTransport`]: what the remote drivers (the coordinator and the
//! worker of `src/cluster/remote/`) need from a transport between
//! processes, beyond the actors' [`Transport`]: peer names for errors,
//! which peers are still needed, counting at the transport, a clean close,
//! and how each link ended. [`crate::net::tcp::TcpTransport`] and (with the
//! `mpi` feature) `crate::net::mpi::MpiTransport` implement it; node,
//! manager and compositor code still see only [`Transport`].

use std::time::Duration;

use serde::{Deserialize, Serialize};

use super::message::NodeId;
use super::metered::TrafficStats;
use super::transport::Transport;

/// Bytes on the wire, counted by the transport.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct WireStats {
    /// Payload messages and bytes per kind (as in the simulator).
    pub payload: TrafficStats,
    /// Bytes written: data frames (tag + header + payload), heartbeats,
    /// goodbyes (TCP); kind byte + payload per message, goodbyes (MPI).
    pub wire_bytes_sent: u64,
    /// Bytes read in frames (TCP) or messages (MPI).
    pub wire_bytes_recv: u64,
    /// Heartbeats written (TCP only; MPI has none).
    pub heartbeats_sent: u64,
    /// Heartbeats read.
    pub heartbeats_recv: u64,
}

impl WireStats {
    /// Adds another endpoint's counts.
    pub fn merge(&mut self, o: &WireStats) {
        self.payload.merge(&o.payload);
        self.wire_bytes_sent += o.wire_bytes_sent;
        self.wire_bytes_recv += o.wire_bytes_recv;
        self.heartbeats_sent += o.heartbeats_sent;
        self.heartbeats_recv += o.heartbeats_recv;
    }
}

/// A rank's endpoint on a network of processes (see the module docs).
pub trait RemoteTransport: Transport {
    /// The name of a peer for error messages, e.g. `worker 2 (10.0.0.3:4711)`.
    fn peer_name(&self, rank: NodeId) -> String;

    /// Marks a peer as needed: its clean end (`Goodbye`) is then an error
    /// (it left before it was done), not a clean end.
    fn set_essential(&self, rank: NodeId, essential: bool);

    /// Counts so far.
    fn stats(&self) -> WireStats;

    /// Says `Goodbye` to every peer and waits (at most `wait`) for the
    /// queued messages to leave. Later sends fail or are dropped.
    fn close(&self, wait: Duration);

    /// Closes after this rank's frame failed (`since`: when the frame
    /// began). If this process was itself not running for a while since
    /// then, long enough that its peers may have declared it lost (see
    /// [`crate::net::stall`]), it ends its links as a lost rank would
    /// (the queued messages leave, then no `Goodbye`): it is the one at
    /// fault, and a clean end would hide that from a coordinator that
    /// reassigns lost workers' shares. Otherwise as [`Self::close`].
    /// Returns whether it closed as lost. The default (MPI, where a lost
    /// rank ends the job) always closes cleanly.
    fn close_after_failure(&self, since: std::time::Instant, wait: Duration) -> bool {
        let _ = since;
        self.close(wait);
        false
    }

    /// The peers this rank lost (links that ended without `Goodbye`:
    /// closed, or silent past this rank's deadline), for a failure report
    /// that blames them, so that a coordinator whose own deadline has not
    /// passed yet drops the right worker. None if this process was itself
    /// not running long enough since `since` for the silence to be its own
    /// (see [`Self::close_after_failure`]). The default (MPI: a lost rank
    /// ends the job) blames no one.
    fn lost_peers(&self, since: std::time::Instant) -> Vec<NodeId> {
        let _ = since;
        Vec::new()
    }

    /// Another rank reported `rank` lost ([`Self::lost_peers`]): its link
    /// counts as lost ([`Self::link_endings`] says `Some(false)`), as if
    /// this rank's own deadline had passed, and closes without `Goodbye`.
    /// The default (MPI) does nothing.
    fn blame(&self, rank: NodeId) {
        let _ = rank;
    }

    /// How each rank's link ended, after waiting at most `wait` for the
    /// links still open to end (messages read meanwhile are dropped):
    /// `Some(true)` a clean `Goodbye`, `Some(false)` lost, `None` still
    /// open (or no link). For a caller whose frame failed: which peers
    /// died, and which only gave up.
    fn link_endings(&self, wait: Duration) -> Vec<Option<bool>>;
}
