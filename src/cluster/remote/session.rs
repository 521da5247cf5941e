//! The session messages between the coordinator and a worker process, and
//! the set-up a worker rebuilds its node from. They travel as `Session`
//! messages, outside the actors' protocol: before the node starts and after
//! it stopped.
//!
//! ```text
//! coordinator → worker  Setup        rank, peers, scene, options, hash of its cells
//! worker → coordinator  Need(bool)   true: the cells are not in its cache
//! coordinator → worker  Cells        WorkUnit::encode bytes (only if needed;
//!                                    never when the set-up names pieces the
//!                                    worker reads itself, see super::pieces)
//! (workers dial lower ranks, accept higher ones: a full mesh)
//! worker → coordinator  Ready        every peer link is up, the node is built
//! coordinator → worker  Go           phase 1 starts (the worker's clock starts)
//!      ... phase 1: NodeActor ⇄ ManagerActor and peers, unchanged ...
//! worker → coordinator  Result       stats, traffic, timeline
//! coordinator → worker  Composite    every node is done: phase 2 starts
//!      ... phase 2: the compositor's rounds worker to worker (remote::phase2),
//!          the gathered pixels (MessageKind::Image) to the coordinator ...
//! worker → coordinator  Phase2Done   its phase-2 log and transport counts
//!      ... the session stays up: the links, the cells (decoded) or the
//!          pieces (read) are kept for the next frame ...
//! coordinator → worker  Setup        the next frame over the same links
//!                                    (same rank, nodes and peers)
//! worker → every peer   Flush        its last message of the frame before
//!                                    (links are FIFO: what came before it
//!                                    is stale and dropped)
//! worker → coordinator  Need(bool)   as above, then Cells, Ready, Go, ...
//! coordinator → worker  End          the session is over: links close
//! worker → coordinator  Lost, Failed on a failure: the peers it lost (if
//!                                    any, and it was itself running), then
//!                                    why
//! ```

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::cluster::report::NodeRaw;
use crate::net::tcp::WireStats;
use crate::net::{Message, MessageKind, SimTrace, TrafficStats};
use crate::node::renderer::NodeErt;
use crate::node::{CostProfile, NodeOptions, NodePolicy};
use crate::render::cell::{CellOrder, ErtSpan, Integrator};

/// Session messages (see the module docs).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub enum Session {
    /// What the worker's node is.
    Setup(Box<WorkerSetup>),
    /// The worker needs the cells (its cache does not hold the hash).
    Need(bool),
    /// The cells: [`crate::node::WorkUnit::encode`] bytes.
    Cells(Vec<u8>),
    /// All peer links are up and the node is built.
    Ready {
        /// Its unprocessed cells (the manager's initial load figure).
        remaining: u64,
    },
    /// Start phase 1.
    Go,
    /// The node's outcome.
    Result(Box<NodeResult>),
    /// The worker could not set up its node (bad set-up, bad cells, mesh
    /// failed) or failed later: the reason, for the coordinator's error.
    Failed(String),
    /// Every node is done with phase 1: run phase 2 (coordinator → worker).
    Composite,
    /// The worker's phase 2 is done: what it sent and merged, and what its
    /// transport counted in phase 2.
    Phase2Done(Box<(super::phase2::RankLog, WireStats)>),
    /// A grid scene's session (bricks instead of cells, see [`super::grid`]).
    Grid(Box<super::grid_wire::GridMsg>),
    /// The session is over (coordinator → worker): no frame follows, the
    /// links close cleanly.
    End,
    /// A worker's last message to a peer before the next frame (worker →
    /// worker, sent when the next `Setup` arrives): what the peer read
    /// from this link before it belongs to the frame before.
    Flush,
    /// The peers (ranks) a failing worker lost: their links to it ended
    /// without `Goodbye` (closed, or silent past its deadline), sent just
    /// before its `Failed` (worker → coordinator). The coordinator counts
    /// them lost as if its own link to them had ended, so that a stalled
    /// worker is the one dropped even when a peer's deadline passes first.
    Lost(Vec<u32>),
}

impl Message for Session {
    const KIND: MessageKind = MessageKind::Session;
}

/// ERT options of a node ([`NodeErt`] on the wire).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WireErt {
    /// See [`NodeErt::threshold`].
    pub threshold: f32,
    /// See [`NodeErt::divisions`].
    pub divisions: u32,
    /// See [`NodeErt::update_c`].
    pub update_c: u32,
    /// See [`NodeErt::span`].
    pub span: ErtSpan,
    /// See [`NodeErt::structure`].
    pub structure: crate::render::cell::ert::ErtStructure,
    /// See [`NodeErt::share_levels`].
    pub share_levels: u8,
    /// See [`NodeErt::share_sub`].
    pub share_sub: u8,
}

/// Node renderer options ([`NodeOptions`] on the wire).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WireNodeOptions {
    /// Integrator.
    pub integrator: Integrator,
    /// Partial composition.
    pub partial_composition: bool,
    /// Cell order.
    pub cell_order: CellOrder,
    /// ERT.
    pub ert: WireErt,
    /// Canonical lists.
    pub canonical: bool,
}

impl From<NodeOptions> for WireNodeOptions {
    fn from(o: NodeOptions) -> Self {
        let e = o.ert;
        WireNodeOptions {
            integrator: o.integrator,
            partial_composition: o.partial_composition,
            cell_order: o.cell_order,
            ert: WireErt {
                threshold: e.mode.threshold(),
                divisions: e.divisions,
                update_c: e.update_c,
                span: e.span,
                structure: e.structure,
                share_levels: e.share_levels,
                share_sub: e.share_sub,
            },
            canonical: o.canonical,
        }
    }
}

impl From<WireNodeOptions> for NodeOptions {
    fn from(o: WireNodeOptions) -> Self {
        let e = o.ert;
        NodeOptions {
            integrator: o.integrator,
            partial_composition: o.partial_composition,
            cell_order: o.cell_order,
            ert: NodeErt {
                mode: crate::render::cell::ert::ErtMode::of_threshold(e.threshold),
                divisions: e.divisions,
                update_c: e.update_c,
                span: e.span,
                structure: e.structure,
                share_levels: e.share_levels,
                share_sub: e.share_sub,
            },
            canonical: o.canonical,
        }
    }
}

/// Pacing knobs ([`NodePolicy`] on the wire).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WirePolicy {
    /// See [`NodePolicy::chunk`].
    pub chunk: u64,
    /// See [`NodePolicy::give_fraction`].
    pub give_fraction: f64,
    /// See [`NodePolicy::min_grant`].
    pub min_grant: u64,
    /// See [`NodePolicy::progress_every`].
    pub progress_every: u32,
    /// See [`NodePolicy::share_window`].
    pub share_window: u32,
    /// See [`NodePolicy::help_gap`].
    pub help_gap: f32,
    /// See [`NodePolicy::help_fraction`].
    pub help_fraction: f64,
}

impl From<NodePolicy> for WirePolicy {
    fn from(p: NodePolicy) -> Self {
        WirePolicy {
            chunk: p.chunk as u64,
            give_fraction: p.give_fraction,
            min_grant: p.min_grant as u64,
            progress_every: p.progress_every,
            share_window: p.share_window,
            help_gap: p.help_gap,
            help_fraction: p.help_fraction,
        }
    }
}

impl From<WirePolicy> for NodePolicy {
    fn from(p: WirePolicy) -> Self {
        NodePolicy {
            chunk: usize::try_from(p.chunk).unwrap_or(usize::MAX),
            give_fraction: p.give_fraction,
            min_grant: usize::try_from(p.min_grant).unwrap_or(usize::MAX),
            progress_every: p.progress_every,
            share_window: p.share_window,
            help_gap: p.help_gap,
            help_fraction: p.help_fraction,
            release_block: 0,
            release_lag: 0.0,
        }
    }
}

/// Everything a worker needs to build its node, except the cells.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct WorkerSetup {
    /// This worker's rank.
    pub rank: u32,
    /// Number of nodes `N` (the coordinator is rank `N`).
    pub nodes: u32,
    /// Every worker's address, by rank (the worker dials the lower ranks).
    pub peers: Vec<String>,
    /// The scene as TOML (camera, image, transfer function; the data path
    /// is not read).
    pub scene_toml: String,
    /// Depth range `[z0, z1]` of the frame (per-pixel sharing's depth codes;
    /// the same on every node and the manager).
    pub depth_range: [f32; 2],
    /// Renderer options.
    pub node: WireNodeOptions,
    /// Weak sharing through the manager.
    pub share: bool,
    /// Dynamic load balancing.
    pub dlb: bool,
    /// Pacing.
    pub policy: WirePolicy,
    /// Overlap sharing: the ranks this node sends its table to.
    pub overlap_peers: Vec<u32>,
    /// Compute cost profile (charged as in the thread driver: not slept).
    pub profile: CostProfile,
    /// List codec of phase 2 (travels as its name, `rle` or `raw`; an
    /// unknown name fails decoding).
    pub list_codec: crate::compositor::codec::ListCodecKind,
    /// Compositing strategy of phase 2 (travels as its name, e.g.
    /// `binary-swap`, `radix-k:4`).
    pub compositor: crate::compositor::strategy::Compositing,
    /// Payload limit of frames.
    pub max_message_bytes: u64,
    /// Cells placed on this node.
    pub cells_initial: u64,
    /// SHA-256 of the cells' bytes (the cache key).
    pub cells_sha256: [u8; 32],
    /// Partitioned data read where it is used: the pieces this worker reads
    /// itself ([`super::pieces`]); no cells are sent (its `Need` is false).
    pub pieces: Option<super::pieces::PieceSource>,
    /// Longest wait for a message in phase 1 before giving up (seconds).
    pub recv_timeout_s: f64,
    /// The frame's random id (the same in every worker's set-up): a mesh
    /// peer states it after its handshake, so a link left over from an
    /// earlier frame is never taken into this one.
    pub session_id: [u8; 16],
}

/// A fresh random frame id for [`WorkerSetup::session_id`] and
/// [`GridSetup::session_id`](super::grid_wire::GridSetup::session_id).
pub fn new_session_id() -> [u8; 16] {
    let mut id = [0u8; 16];
    // A failing system RNG leaves a fixed id: links are still
    // authenticated, only stale-link detection weakens.
    let _ = getrandom::fill(&mut id);
    id
}

impl WorkerSetup {
    /// The phase-1 options on the worker's side.
    pub fn node_options(&self) -> NodeOptions {
        self.node.into()
    }

    /// Checks what a worker cannot take on trust.
    pub fn validate(&self) -> Result<(), String> {
        if self.nodes == 0 || self.rank >= self.nodes {
            return Err(format!("rank {} of {} nodes", self.rank, self.nodes));
        }
        if self.peers.len() != self.nodes as usize {
            return Err(format!(
                "{} peer addresses for {} nodes",
                self.peers.len(),
                self.nodes
            ));
        }
        if let Some(p) = self.overlap_peers.iter().find(|&&p| p >= self.nodes) {
            return Err(format!("overlap peer {p} is not a node"));
        }
        if !(self.recv_timeout_s.is_finite() && self.recv_timeout_s > 0.0) {
            return Err(format!("recv timeout {} s", self.recv_timeout_s));
        }
        let t = self.node.ert.threshold;
        if !(t.is_finite() && t > 0.0 && t <= 1.0) {
            return Err(format!("ERT threshold {t} (must be in (0, 1])"));
        }
        if let Some(p) = &self.pieces {
            // A worker reads only `.pvtu` files (and the pieces they name,
            // under their folder) for a coordinator.
            if !p.pvtu.to_ascii_lowercase().ends_with(".pvtu") {
                return Err(format!("pieces of {:?}: not a .pvtu", p.pvtu));
            }
            if !(p.range[0].is_finite() && p.range[1].is_finite()) {
                return Err(format!("pieces: scalar range {:?}", p.range));
            }
        }
        Ok(())
    }
}

/// SHA-256 of `bytes`.
pub fn sha256(bytes: &[u8]) -> [u8; 32] {
    Sha256::digest(bytes).into()
}

/// What a worker sends back after phase 1.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct NodeResult {
    /// Its numbers for the report.
    pub raw: NodeRaw,
    /// When its node stopped (seconds after `Go`).
    pub stopped_at: f64,
    /// Its timeline (seconds after `Go`).
    pub trace: SimTrace,
    /// Payload traffic its node sent and received (counted by the driver).
    pub traffic: TrafficStats,
    /// Bytes its transport wrote and read in phase 1.
    pub wire: WireStats,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_round_trip_through_the_wire_forms() {
        let o = NodeOptions {
            canonical: true,
            ..Default::default()
        };
        assert_eq!(NodeOptions::from(WireNodeOptions::from(o)), o);
        let p = NodePolicy::default();
        assert_eq!(NodePolicy::from(WirePolicy::from(p)), p);
    }
}
