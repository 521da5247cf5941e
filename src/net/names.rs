//! The names a message carries: the rank of its sender and receiver
//! ([`NodeId`]) and its kind ([`MessageKind`]). Below [`super::message`]
//! (envelopes, codec) and [`super::error`] (which names both), so that those
//! two do not import each other; `net::message` re-exports them.

use std::fmt;

use serde::{Deserialize, Serialize};

/// The rank of a node (or the manager) in a network of `size` ranks,
/// `0..size`.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct NodeId(pub u32);

impl NodeId {
    /// The rank as an index into per-rank arrays.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl From<usize> for NodeId {
    /// Converts an index; ranks are `u32`, so indices above `u32::MAX`
    /// saturate (no network has that many ranks).
    fn from(i: usize) -> Self {
        NodeId(u32::try_from(i).unwrap_or(u32::MAX))
    }
}

impl fmt::Display for NodeId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "rank {}", self.0)
    }
}

/// What a message is for. Used to report bytes per kind and to check that a
/// payload is decoded as the type it was encoded from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum MessageKind {
    /// A node's local ERT table sent to the manager (1 bit + one depth per
    /// subscreen entry).
    ErtShare,
    /// The manager's merged ERT table sent back to a node.
    ErtReply,
    /// An idle node asks for work (dynamic load balancing).
    WorkRequest,
    /// Cells handed over, with the vertex data they need.
    WorkGrant,
    /// Ray-segment lists of a screen region, sent to the region's owner.
    Segments,
    /// Composited image pixels (binary swap halves, the final gather).
    Image,
    /// Anything else: start, stop, barriers, acknowledgements.
    Control,
    /// Between a coordinator and its worker processes, outside the actors'
    /// protocol: set-up, readiness, results, a worker's failure report
    /// (`crate::cluster::remote::session`). Never delivered to an actor.
    Session,
}

impl MessageKind {
    /// Every kind, in code order.
    pub const ALL: [MessageKind; 8] = [
        MessageKind::ErtShare,
        MessageKind::ErtReply,
        MessageKind::WorkRequest,
        MessageKind::WorkGrant,
        MessageKind::Segments,
        MessageKind::Image,
        MessageKind::Control,
        MessageKind::Session,
    ];

    /// The kind's one-byte code in a frame header.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The kind for a frame-header code, or `None` for an unknown code.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(usize::from(code)).copied()
    }

    /// Name used in reports, e.g. `ert-share`.
    pub fn name(self) -> &'static str {
        match self {
            MessageKind::ErtShare => "ert-share",
            MessageKind::ErtReply => "ert-reply",
            MessageKind::WorkRequest => "work-request",
            MessageKind::WorkGrant => "work-grant",
            MessageKind::Segments => "segments",
            MessageKind::Image => "image",
            MessageKind::Control => "control",
            MessageKind::Session => "session",
        }
    }
}

impl fmt::Display for MessageKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
