//! Grid scenes over `--transport processes|tcp`: the paper's setting, slave
//! processes that render their bricks and send the subimages to a master
//! (`parallel-texture-vr-rle.txt`, PVM over 100BASE), here the coordinator.
//!
//! ```text
//! coordinator → worker  Session::Grid(Setup)  rank, scene (the view), options, bricks' places, SHA-256 of their samples
//! worker → coordinator  Session::Need(bool)   true: the samples are not in its cache
//! coordinator → worker  Session::Cells(bytes) the bricks' samples (grid_wire), only if needed
//!      ... the worker renders its bricks into layers (GridNodeActor, as on the other clocks) ...
//! worker → coordinator  Session::Grid(Result) its stats and its layers, encoded by the layer codec
//! coordinator           decodes the layers strictly and runs phase 2 with the
//!                       same code as the other clocks (cluster::grid::finish)
//! ```
//!
//! A worker gets its bricks once: they are cached by content hash across
//! sessions (as cells are), so a later frame sends only the view. The
//! worker renders with the same code as the threads and the simulator, and
//! the layer codecs are lossless at their depth, so the coordinator holds
//! the same layers bit for bit and composites the same image. Only the
//! master compositor runs here (the workers send to the master, as in the
//! paper); binary swap and direct send between grid workers are refused.
//!
//! Files: this one holds the messages and the coordinator's options,
//! `coordinator.rs` runs a frame from the coordinator's side (set-ups,
//! results, the master's or the workers' compositing), `serve.rs` is the
//! worker's side of a grid session. Joining the mesh of peers is
//! [`super::mesh`].

mod coordinator;
mod serve;

pub(super) use serve::serve;
pub use serve::GridWorkerCache;

use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::cluster::remote::grid_wire::GridSetup;
use crate::cluster::remote::phase2::RankLog;
use crate::net::tcp::{TcpOptions, Token};
use crate::node::grid::GridNodeStats;

/// The grid messages inside [`Session::Grid`](super::session::Session::Grid).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub enum GridMsg {
    /// The worker's frame.
    Setup(Box<GridSetup>),
    /// What the worker rendered.
    Result(Box<GridResult>),
    /// Phase 2 worker to worker: the rank's log, after its last send.
    Done(Box<RankLog>),
}

/// A worker's frame result.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GridResult {
    /// Its numbers (`host_s` is its measured render time).
    pub stats: GridNodeStats,
    /// Its layers cropped to the screen, empty ones dropped, as one
    /// [`encode`](crate::compositor::layer::exec::encode) message under the setup's codec (empty when
    /// the workers composite among themselves).
    pub layers: Vec<u8>,
}

/// What the transport measured, beside the report.
#[derive(Debug, Clone, Default, Serialize)]
pub struct GridMeasured {
    /// `processes` or `tcp`.
    pub transport: String,
    /// Bytes of brick samples sent (0 when every worker had them cached).
    pub bricks_bytes_sent: u64,
    /// Workers that had their bricks cached.
    pub bricks_cached: usize,
    /// Layer message bytes the workers sent (the subimages, encoded).
    pub layer_bytes: u64,
    /// Session payload bytes of the results (layers plus stats).
    pub result_payload_bytes: u64,
    /// Seconds to connect and send set-ups and bricks.
    pub setup_s: f64,
    /// Seconds from the last set-up sent to the last result in.
    pub collect_s: f64,
    /// Seconds of the master's compositing.
    pub composite_s: f64,
    /// Worker to worker: per rank, its phase-2 wall and thread CPU seconds
    /// (from its log; empty with a master).
    pub phase2_ranks: Vec<(f64, f64)>,
    /// Worker to worker: seconds from the last worker's render result to
    /// the last pixels in (phase 2 once every node has rendered; 0 with a
    /// master).
    pub phase2_after_renders_s: f64,
    /// Set when `--on-failure reassign` moved lost workers' bricks to the
    /// survivors (who, when, in which phase, the cost).
    pub reassigned: Option<crate::cluster::remote::reassign::Reassigned>,
}

/// How the coordinator reaches its grid workers.
#[derive(Debug, Clone)]
pub struct GridRemote {
    /// Worker addresses, one per rendering node.
    pub workers: Vec<String>,
    /// The shared token.
    pub token: Token,
    /// Link timing.
    pub tcp: TcpOptions,
    /// Longest wait for a worker's result.
    pub recv_timeout: Duration,
    /// `processes` or `tcp` (for the report).
    pub transport: String,
    /// `--on-failure reassign`: the bricks of workers lost at any phase go
    /// to the survivors and the frame runs again on them.
    pub reassign: bool,
}
