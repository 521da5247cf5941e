//! The report's records: [`ClusterReport`] (the JSON written by
//! `--report`), one [`NodeReport`] per node, the raw per-node numbers a
//! worker sends ([`NodeRaw`]), the reference runs ([`References`]) and the
//! one-time cost of replicated data ([`Replication`]).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::cluster::ClockKind;
use crate::compositor::CompositeStats;
use crate::manager::ManagerStats;
use crate::node::{NodeActor, NodeStats};
use crate::render::RenderInput;

/// Reference runs for the ratios.
#[derive(Debug, Clone, Copy)]
pub struct References {
    /// Modelled seconds of the sequential run (one node, every cell).
    pub seq_s: f64,
    /// Cells it skipped by ERT.
    pub seq_skipped: u64,
    /// `tsc_max_s` of the Base cluster (`None`: this run is Base).
    pub base_tsc_max_s: Option<f64>,
}

/// A node's numbers taken from its actor before phase 2 (serde: a worker
/// process sends them to the coordinator).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct NodeRaw {
    pub(super) stats: NodeStats,
    pub(super) processed: u64,
    pub(super) skipped: u64,
    pub(super) culled: u64,
    pub(super) stored: u64,
    /// Peak resident memory of the worker process that ran the node
    /// (bytes, taken when its phase 1 ends); `None` when the node ran in
    /// the coordinator's process (virtual clock, threads).
    #[serde(default)]
    pub(super) peak_rss_bytes: Option<u64>,
    /// Distinct vertices of the node's initial part, when the driver
    /// knows the placement (virtual clock, threads): the modelled memory's
    /// vertex term.
    #[serde(default)]
    pub(super) vertices_initial: Option<u64>,
}

impl NodeRaw {
    /// The node's first error, if it failed.
    pub fn error(&self) -> Option<&str> {
        self.stats.error.as_deref()
    }

    /// Reads the actor.
    pub fn from_actor(a: &NodeActor) -> NodeRaw {
        let t = a.renderer().totals();
        NodeRaw {
            stats: a.stats().clone(),
            processed: a.renderer().processed() as u64,
            skipped: t.cells_skipped_ert,
            culled: t.cells_culled,
            stored: a
                .renderer()
                .lists()
                .lists()
                .iter()
                .map(|l| l.len() as u64)
                .sum(),
            peak_rss_bytes: None,
            vertices_initial: None,
        }
    }

    /// The same numbers with the node's initial vertex count (for
    /// [`NodeReport::modelled_bytes`]).
    pub fn with_vertices_initial(mut self, vertices: u64) -> NodeRaw {
        self.vertices_initial = Some(vertices);
        self
    }

    /// The same numbers with the calling process's peak resident memory
    /// (a worker process, before it sends its result).
    pub fn with_process_peak_rss(mut self) -> NodeRaw {
        self.peak_rss_bytes = crate::net::cpu::peak_rss_bytes();
        self
    }
}

/// One node's line of the report.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct NodeReport {
    /// Rank.
    pub rank: usize,
    /// Scan-conversion time: end of the node's last scan chunk (s).
    pub tsc_s: f64,
    /// Busy seconds scanning (chunks + ERT updates).
    pub scan_s: f64,
    /// Of which ERT table updates.
    pub update_s: f64,
    /// Seconds applying shared tables.
    pub share_s: f64,
    /// Seconds packing/unpacking stolen cells.
    pub steal_s: f64,
    /// Phase-1 seconds with nothing to do (phase-1 end − busy).
    pub idle_s: f64,
    /// Phase-2 compute seconds (merging and compositing), modelled; `null`
    /// on the wall clock (the host composites all nodes on one thread).
    pub composite_s: Option<f64>,
    /// Cells placed on the node.
    pub cells_initial: u64,
    /// Cells processed (tested, skipped or scanned), own and taken.
    pub cells_processed: u64,
    /// Of which skipped by ERT.
    pub cells_skipped_ert: u64,
    /// Cells culled on arrival (empty, off screen).
    pub cells_culled: u64,
    /// Cells given away (DLB).
    pub cells_given: u64,
    /// Cells taken from others (DLB).
    pub cells_taken: u64,
    /// ERT tables sent to the manager.
    pub shares_sent: u64,
    /// Work requests sent.
    pub requests_sent: u64,
    /// Payload bytes sent, phases 1 and 2.
    pub bytes_sent: u64,
    /// Of which phase 1.
    pub bytes_sent_phase1: u64,
    /// List entries (segments or merged pieces) the node holds at the end
    /// of phase 1: its list memory, 24 bytes each.
    pub segments_stored: u64,
    /// Real transports with worker processes (`processes`, `tcp`, `mpi`):
    /// the worker's peak resident memory in bytes (`getrusage` `ru_maxrss`,
    /// = `VmHWM`), taken at the end of its phase 1 and sent with its
    /// result; `null` when the nodes ran inside one process.
    pub peak_rss_bytes: Option<u64>,
    /// Modelled memory of the node in bytes, when the driver knows its
    /// placement (virtual clock, threads): its initial part's vertices at
    /// 28 B (3 × f64 position, f32 scalar, as [`crate::node::Replica::node_bytes`]
    /// counts them) and cells at 16 B (4 × u32), each taken cell at
    /// 16 + 4 × 28 B (a cell moved with its four vertices), and its list
    /// entries at 24 B (`segments_stored`). Not counted: the renderer's
    /// per-cell derived arrays and the image buffers. `null` on worker
    /// processes (they report `peak_rss_bytes`).
    pub modelled_bytes: Option<u64>,
}

/// Cost of the ERT exchanges: per exchange, from the share leaving the
/// node's NIC to the reply arriving at it (virtual clock; wall: between the
/// zero-length send and receive marks).
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct TShare {
    /// Exchanges.
    pub exchanges: usize,
    /// Mean seconds.
    pub mean_s: f64,
    /// Longest.
    pub max_s: f64,
    /// Every exchange, node by node (omitted above 20,000).
    pub per_exchange_s: Vec<f64>,
}

/// Host-time measurements (vary from run to run).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct WallInfo {
    /// Host seconds of phase 1 (simulation or threads).
    pub host_phase1_s: f64,
    /// Host seconds of phase 2 (real compositing plus its replay).
    pub host_phase2_s: f64,
}

/// The report of one cluster run.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ClusterReport {
    /// Scene image size.
    pub image: [u32; 2],
    /// Cells in the mesh.
    pub cells_total: u64,
    /// Number of nodes (the manager is extra).
    pub n_nodes: usize,
    /// `virtual` or `wall`.
    pub clock: ClockKind,
    /// Network model name (`n/a (wall clock)` when no time is modelled).
    pub network: String,
    /// Cost profile name (`n/a (wall clock)` when no time is modelled).
    pub profile: String,
    /// Placement method.
    pub placement: String,
    /// Compositing strategy.
    pub compositor: String,
    /// Codec.
    pub codec: String,
    /// ERT threshold (1 = off).
    pub ert_threshold: f32,
    /// ERT table divisions D.
    pub ert_table: u32,
    /// ERT update constant C.
    pub ert_update: u32,
    /// Weak sharing on (only with ERT), through the manager or overlap.
    pub share: bool,
    /// ERT sharing mode: `off`, `manager` or `overlap`.
    pub sharing: String,
    /// Level sharing ([`crate::node::levels`]): opacity levels per block
    /// (1 with `share_sub` 1: the paper's per-entry table).
    pub share_levels: u8,
    /// Level sharing: blocks per entry axis.
    pub share_sub: u8,
    /// Most ERT shares in flight per node (0: no limit, the paper's protocol).
    pub share_window: u32,
    /// ERT structure nodes test against: `pyramid` (per-pixel, with
    /// per-pixel level sharing) or `flat` (the paper's table).
    pub ert_structure: String,
    /// Front-first help gap, fraction of the depth range (0: off).
    pub help_gap: f32,
    /// Front-first help forwards the manager sent.
    pub help_forwards: u64,
    /// Where the cells live: `replicated` (the whole mesh on every node;
    /// DLB and help move cell ids) or `partitioned` (cells move with their
    /// vertices).
    pub data: crate::node::DataMode,
    /// Replicated data: the one-time cost of putting the whole mesh on every
    /// node (not part of any frame time).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub replication: Option<Replication>,
    /// DLB on.
    pub dlb: bool,
    /// Nodes kept canonical lists (image independent of the distribution).
    pub canonical: bool,
    /// Phase 1 + phase 2 (s).
    pub frame_s: f64,
    /// End of phase 1: the last node told to finish (s).
    pub phase1_s: f64,
    /// Slowest node's scan-conversion time (the paper's Table 2 figure).
    pub tsc_max_s: f64,
    /// Mean over nodes.
    pub tsc_mean_s: f64,
    /// Fastest node.
    pub tsc_min_s: f64,
    /// `tsc_max / tsc_mean − 1`.
    pub imbalance: f64,
    /// Sum over nodes of seconds applying shared tables.
    pub share_s_total: f64,
    /// Sum over nodes of DLB packing/unpacking seconds.
    pub steal_s_total: f64,
    /// Sum over nodes of phase-1 idle seconds.
    pub idle_s_total: f64,
    /// Phase 2 (compositing and gather to rank 0), seconds.
    pub composite_s: f64,
    /// Payload bytes of all messages, both phases.
    pub bytes_total: u64,
    /// Payload bytes per message kind (`ert-share`, `ert-reply`,
    /// `work-request`, `work-grant`, `segments`, `image`, `control`).
    pub bytes_by_kind: BTreeMap<String, u64>,
    /// Messages per kind.
    pub messages_by_kind: BTreeMap<String, u64>,
    /// ERT exchange times.
    pub t_share: TShare,
    /// The manager.
    pub manager: ManagerStats,
    /// Modelled seconds the manager spent merging tables (`manager.busy_s`):
    /// compare with `phase1_s` to see when it is the bottleneck.
    pub manager_busy_s: f64,
    /// Manager shards `K` (`--manager-shards`; 1: one manager).
    pub manager_shards: usize,
    /// Busy seconds of the busiest manager shard (shard 0, the manager,
    /// included; `manager_busy_s` when `K = 1`). Per shard:
    /// `manager.shard_busy_s`.
    pub shard_busy_max_s: f64,
    /// List entries held by all nodes at the end of phase 1 (sum of
    /// `nodes[].segments_stored`).
    pub segments_stored: u64,
    /// Cells processed by all nodes (a cell given away is counted once, by its taker).
    pub cells_processed: u64,
    /// Cells skipped by ERT on all nodes.
    pub cells_skipped_ert: u64,
    /// Cells moved by DLB.
    pub cells_moved: u64,
    /// Global front-to-back schedule ([`crate::node::schedule`]): waves
    /// used (0: off).
    pub schedule_waves: usize,
    /// Global schedule: cells per leaf.
    pub schedule_leaf_cells: usize,
    /// Global schedule: the placement's stacking along the view the nodes
    /// computed (`null`: no schedule computed).
    pub schedule_stacking: Option<f64>,
    /// Global schedule: applied (stacking at least the threshold).
    pub schedule_applied: bool,
    /// Global schedule: cells dealt to another node than their placement
    /// part's (computed on every node; no byte travels).
    pub cells_scheduled: u64,
    /// Modelled seconds of the sequential run at the same settings.
    pub sequential_s: Option<f64>,
    /// Cells it skipped by ERT.
    pub sequential_skipped: Option<u64>,
    /// `tsc_max_s` of Base (ERT, sharing, DLB off) at the same N.
    pub base_tsc_max_s: Option<f64>,
    /// Cells skipped by all nodes ÷ cells skipped by the sequential run
    /// (1: the cluster skips as much as one machine; `null` without ERT).
    pub share_efficiency: Option<f64>,
    /// Base `tsc_max_s` ÷ (sequential time / N).
    pub ideal_speedup: Option<f64>,
    /// Sequential time ÷ `tsc_max_s` (scan conversion only, the paper's measure).
    pub speedup: Option<f64>,
    /// `speedup / N`.
    pub efficiency: Option<f64>,
    /// Sequential time ÷ `frame_s` (phase 1 + compositing: what a user waits for).
    pub speedup_frame: Option<f64>,
    /// `speedup_frame / N`.
    pub efficiency_frame: Option<f64>,
    /// The compositor's counters (bytes per round, raw vs encoded).
    pub compositing: CompositeStats,
    /// One line per node.
    pub nodes: Vec<NodeReport>,
    /// With worker processes: the coordinator's peak resident memory in
    /// bytes (`getrusage` `ru_maxrss`), taken when the report is built
    /// (after phase 2); `null` otherwise.
    pub coordinator_peak_rss_bytes: Option<u64>,
    /// Host-time measurements.
    pub wall: WallInfo,
    /// With a real transport (`--transport processes|tcp`): bytes and
    /// messages measured at the transport beside the virtual model's
    /// prediction for the same frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transport: Option<super::transport::TransportSection>,
    /// Workers that read their own pieces of a `.pvtu`: what they read and
    /// what the transport measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pieces: Option<super::transport::PiecesSection>,
    /// Real transports: per rank and activity, modelled compute beside the
    /// measured thread CPU and wall seconds ([`super::cpu`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cpu: Option<Vec<super::cpu::CpuRank>>,
    /// A series of frames (`--frames N`, on the last frame's report): frames
    /// per second and one row per frame ([`super::series`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub series: Option<super::series::SeriesReport>,
}

/// The one-time cost of replicated data ([`crate::node::replica`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Replication {
    /// Bytes of mesh each node holds (`V · 28 + C · 16`).
    pub node_bytes: u64,
    /// Bytes sent to put the whole mesh on every node (one work unit each).
    pub distribution_bytes: u64,
    /// Seconds of that on the network model if one host sends the units in
    /// turn (each waits for the previous one's arrival): once per dataset,
    /// like the transports' cell cache, not per frame.
    pub distribution_s: f64,
}

impl Replication {
    /// The cost for `n` nodes on `model`.
    pub fn new(input: &RenderInput, n: usize, model: &crate::net::NetworkModel) -> Replication {
        let r = crate::node::Replica::new(input.mesh.clone(), &[]);
        let unit = r.unit_bytes();
        Replication {
            node_bytes: r.node_bytes(),
            distribution_bytes: r.distribution_bytes(n),
            distribution_s: n as f64 * model.uncontended_arrival(0.0, unit),
        }
    }
}
