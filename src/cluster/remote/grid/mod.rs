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
//! Files: this one holds the coordinator's options (the messages are in
//! [`super::grid_wire`], below the session they travel in),
//! `coordinator.rs` runs a frame from the coordinator's side (set-ups,
//! results, the master's or the workers' compositing), `serve.rs` is the
//! worker's side of a grid session. Joining the mesh of peers is
//! [`super::mesh`].

mod coordinator;
mod serve;

pub(super) use serve::serve;
pub use serve::GridWorkerCache;

use std::time::Duration;

pub use crate::cluster::grid::GridMeasured;
pub use crate::cluster::remote::grid_wire::{GridMsg, GridResult};
use crate::net::tcp::{TcpOptions, Token};

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
