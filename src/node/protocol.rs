//! The phase-1 messages. Each is a serde type with its [`MessageKind`], so it
//! travels through the size-limited [`crate::net::Codec`] (bincode, fixed
//! width, validated on decode). Tables and work units are carried as their
//! own compact, validated wire forms ([`crate::node::SharedTable::encode`],
//! [`crate::node::WorkUnit::encode`]), so the bytes charged to the network
//! are the real ones: a table is `4 + ceil(n/8) + 4·terminated` bytes plus
//! the 8-byte length prefix, a work unit exactly its `encoded_size()` plus 8.
//!
//! | message | kind | from → to |
//! |---|---|---|
//! | [`ErtShare`] | `ErtShare` | node → manager, at each of the node's ERT update points |
//! | [`ErtReply`] | `ErtReply` | manager → that node, the merged table |
//! | [`WorkRequest`] | `WorkRequest` | node → manager, "I have no cells left" |
//! | [`WorkForward`] | `WorkRequest` | manager → donor, "give a share to `requester`" |
//! | [`WorkGrant`] | `WorkGrant` | donor → requester, the cells |
//! | [`Control`] | `Control` | progress and grant reports (node → manager), end of phase 1 (manager → node) |

use serde::{Deserialize, Serialize};

use crate::net::{Message, MessageKind};

/// A node's local ERT table and its count of unprocessed cells.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErtShare {
    /// Unprocessed cells of the sender when it sent this (the manager's load
    /// information for DLB).
    pub remaining: u64,
    /// Nearest depth of the sender's next unprocessed cell (`+inf`: none):
    /// its depth frontier, for front-first help.
    pub front: f32,
    /// The sender asks for front cells of a node nearer the eye (front-first
    /// help): it has no help request pending.
    pub help: bool,
    /// The node's ERT information: [`crate::node::SharedTable::encode`],
    /// a level delta, or per-pixel levels, by the run's sharing mode.
    pub table: Vec<u8>,
}

impl Message for ErtShare {
    const KIND: MessageKind = MessageKind::ErtShare;
}

/// The manager's merged table (per entry the minimum `deepest` over the
/// terminated entries received so far).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErtReply {
    /// [`crate::node::SharedTable::encode`] of the merged table.
    pub table: Vec<u8>,
}

impl Message for ErtReply {
    const KIND: MessageKind = MessageKind::ErtReply;
}

/// A node has no unprocessed cells left.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct WorkRequest {
    /// How many non-empty [`WorkGrant`]s the node has received so far; the
    /// manager compares it with the grants it knows were sent to the node, so
    /// a request overtaking a grant report is never mistaken for idleness.
    pub grants_taken: u32,
}

impl Message for WorkRequest {
    const KIND: MessageKind = MessageKind::WorkRequest;
}

/// The manager asks a donor to give a share of its cells to `requester`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct WorkForward {
    /// The idle (or helping) node's rank.
    pub requester: u32,
    /// Front-first help: give the *first* cells in processing order (the
    /// nearest), not the last; answer even a refusal with an empty grant.
    pub front: bool,
}

impl Message for WorkForward {
    const KIND: MessageKind = MessageKind::WorkRequest;
}

/// Cells handed from a donor to an idle node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorkGrant {
    /// [`crate::node::WorkUnit::encode`] of the cells with their vertices.
    pub unit: Vec<u8>,
}

impl Message for WorkGrant {
    const KIND: MessageKind = MessageKind::WorkGrant;
}

/// Small reports and commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Control {
    /// Node → manager: unprocessed cells now (sent with DLB when no
    /// [`ErtShare`] carries the count).
    Progress {
        /// Unprocessed cells.
        remaining: u64,
    },
    /// Donor → manager, after a [`WorkForward`]: `cells` cells went to `to`
    /// (0: the donor had too few to give), and the donor has `remaining` left.
    Gave {
        /// The requester.
        to: u32,
        /// Cells given.
        cells: u64,
        /// The donor's unprocessed cells afterwards.
        remaining: u64,
        /// The forward was front-first help (the requester is not idle).
        help: bool,
    },
    /// Node → manager: the node hit an error (e.g. a message failed to
    /// decode) and stops; the manager ends phase 1 for everyone.
    Abort,
    /// Manager → node: phase 1 is over (no node has cells left).
    Finish,
}

impl Message for Control {
    const KIND: MessageKind = MessageKind::Control;
}
