//! A node's configuration ([`NodeConfig`], its pacing [`NodePolicy`]) and
//! the counters it reports ([`NodeStats`]).

/// How the nodes of a run pace their work, share and give cells.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodePolicy {
    /// Most cells per chunk (the inbox is polled between chunks; an ERT
    /// update point also ends a chunk).
    pub chunk: usize,
    /// Fraction of its unprocessed cells a donor gives (the paper: 1/3).
    pub give_fraction: f64,
    /// Fewest unprocessed cells a donor keeps giving from (below: refuse).
    pub min_grant: usize,
    /// With DLB and no sharing: send a progress report every this many chunks.
    pub progress_every: u32,
    /// Most shares a node keeps in flight to the manager (sent, reply not
    /// yet back); 0 = no limit, the paper's protocol.
    pub share_window: u32,
    /// Front-first help (with DLB and per-pixel sharing), as a fraction of
    /// the frame's depth range (0: off): shares ask the manager for the
    /// nearest cells of the node with the nearest depth frontier, which the
    /// manager grants when this node's frontier lies more than this behind.
    pub help_gap: f32,
    /// Front-first help: fraction of its unprocessed cells a donor gives
    /// (the nearest ones).
    pub help_fraction: f64,
    /// Release ordering ([`crate::node::release`], with per-pixel sharing):
    /// block edge in pixels; 0: off (nearest-first order).
    pub release_block: u32,
    /// Release ordering: how long (fraction of the frame) a cell waits
    /// after the nodes in front of it start covering its blocks.
    pub release_lag: f32,
}

impl Default for NodePolicy {
    /// Chunks of 100 cells, the paper's third, grants from 3 cells, a
    /// progress report every chunk, one share in flight.
    fn default() -> Self {
        NodePolicy {
            chunk: 100,
            give_fraction: 1.0 / 3.0,
            min_grant: 3,
            progress_every: 1,
            share_window: 1,
            help_gap: 0.0,
            help_fraction: 0.25,
            release_block: 0,
            release_lag: 0.0,
        }
    }
}

/// How a node works in phase 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeConfig {
    /// The node's rank.
    pub rank: usize,
    /// The manager's rank.
    pub manager: usize,
    /// Weak sharing of ERT tables through the manager.
    pub share: bool,
    /// Dynamic load balancing.
    pub dlb: bool,
    /// Pacing and work-giving knobs, the same for every node of a run.
    pub policy: NodePolicy,
}

/// What a node did in phase 1 (times are the driver's: virtual or wall).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NodeStats {
    /// End of the node's last scan chunk: its scan-conversion time `Tsc`.
    pub tsc_s: f64,
    /// Seconds of scan conversion (chunks and ERT updates).
    pub scan_s: f64,
    /// Of which ERT table updates.
    pub update_s: f64,
    /// Seconds applying the manager's tables.
    pub share_s: f64,
    /// Seconds packing and unpacking stolen cells.
    pub steal_s: f64,
    /// Cells placed on the node at the start.
    pub cells_initial: u64,
    /// Cells given away (DLB).
    pub cells_given: u64,
    /// Cells taken from others (DLB).
    pub cells_taken: u64,
    /// Global schedule ([`crate::node::schedule`]): cells of this node's
    /// placement part dealt to other nodes for the frame (nothing travels).
    #[serde(default)]
    pub cells_scheduled_out: u64,
    /// Global schedule: cells of other nodes' parts dealt to this node.
    #[serde(default)]
    pub cells_scheduled_in: u64,
    /// Global schedule: leaves keyed at the start (0: no schedule computed).
    #[serde(default)]
    pub schedule_keyed: u64,
    /// Global schedule: the placement's stacking along the view
    /// ([`crate::node::schedule::stacking`]), which decides whether the
    /// schedule computed is applied.
    #[serde(default)]
    pub schedule_stacking: f64,
    /// Global schedule: applied (else the node scans its placement part).
    #[serde(default)]
    pub schedule_applied: bool,
    /// Tables sent to the manager.
    pub shares_sent: u64,
    /// Replies applied.
    pub replies_applied: u64,
    /// Work requests sent.
    pub requests_sent: u64,
    /// Payload bytes sent, all kinds.
    pub bytes_sent: u64,
    /// Payload bytes sent per kind (`MessageKind::name`).
    pub bytes_sent_by_kind: std::collections::BTreeMap<String, u64>,
    /// The first error, if the node failed.
    pub error: Option<String>,
}
