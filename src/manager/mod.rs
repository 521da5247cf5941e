//! The manager of the cluster (paper §3.2, §3.3) and the phase-1 protocol
//! between it and the nodes.
//!
//! - [`protocol`] (in `node`): the typed messages of phase 1 (ERT sharing, dynamic load
//!   balancing, progress reports, the end of phase 1).
//! - [`actor`]: the [`ManagerActor`], an [`crate::net::Actor`] that merges
//!   ERT tables (weak sharing), routes work requests to the node with the
//!   most unprocessed cells, and detects the end of phase 1.
//! - [`shard`]: the [`ShardActor`], one screen region of a sharded
//!   manager's per-pixel ERT store (`--manager-shards K`).
//!
//! The node side is [`crate::node::actor::NodeActor`]. The protocol, with the
//! reasons for each choice, is described in `src/manager/README.md`.

pub mod actor;
/// The phase-1 messages live beside the node ([`crate::node::protocol`]), so
/// that `node` needs nothing from `manager`; re-exported under the old path.
pub use crate::node::protocol;
pub mod shard;

pub use actor::{ManagerActor, ManagerConfig, ManagerStats};
pub use protocol::{Control, ErtReply, ErtShare, WorkForward, WorkGrant, WorkRequest};
pub use shard::{ShardActor, ShardStats};
