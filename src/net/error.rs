//! Errors of the communication layer. Peers are untrusted: every malformed
//! byte string becomes a [`NetError`] naming the message kind and what was
//! wrong, never a panic.

use super::names::{MessageKind, NodeId};

/// Anything that can go wrong while encoding, sending, receiving, decoding or
/// simulating messages.
#[derive(Debug, thiserror::Error)]
pub enum NetError {
    /// A value could not be serialised (e.g. it exceeds the size limit).
    #[error("encoding a {kind} message: {msg}")]
    Encode {
        /// Kind of the message being encoded.
        kind: MessageKind,
        /// What went wrong.
        msg: String,
    },
    /// A payload could not be deserialised: truncated, corrupt, or a length
    /// prefix larger than the limit.
    #[error("decoding a {kind} message: {msg}")]
    Decode {
        /// Kind of the message being decoded.
        kind: MessageKind,
        /// What went wrong.
        msg: String,
    },
    /// A payload is larger than the configured maximum message size.
    #[error("{kind} message of {size} bytes exceeds the limit of {limit} bytes (raise `max_message_bytes` if this is legitimate)")]
    TooLarge {
        /// Kind of the message.
        kind: MessageKind,
        /// Its size in bytes.
        size: u64,
        /// The configured limit.
        limit: u64,
    },
    /// An envelope was decoded as the wrong message type.
    #[error("expected a {expected} message but got a {found} message")]
    WrongKind {
        /// The kind the receiver asked for.
        expected: MessageKind,
        /// The kind in the envelope.
        found: MessageKind,
    },
    /// A framed envelope (header + payload) is malformed.
    #[error("malformed frame: {0}")]
    Frame(String),
    /// A message was addressed to a rank outside `0..size`.
    #[error("no such rank {to}: the network has {size} ranks")]
    NoSuchRank {
        /// The bad destination.
        to: NodeId,
        /// Number of ranks.
        size: usize,
    },
    /// The peer's (or our own) endpoint has gone away.
    #[error("{rank}: the channel is disconnected (the peer has shut down)")]
    Disconnected {
        /// The rank that noticed.
        rank: NodeId,
    },
    /// A blocking receive waited longer than allowed (likely a deadlock in
    /// the protocol).
    #[error("{rank}: no message within {seconds} s (protocol deadlock?)")]
    Timeout {
        /// The waiting rank.
        rank: NodeId,
        /// How long it waited.
        seconds: f64,
    },
    /// A network model description is invalid.
    #[error("network model: `{key}`: {msg}")]
    Config {
        /// The offending field.
        key: String,
        /// What is wrong and how to fix it.
        msg: String,
    },
    /// The simulation was driven into an invalid state by an actor (e.g. a
    /// negative or NaN compute time).
    #[error("simulation: {0}")]
    Sim(String),
    /// A connection to a peer failed after it was set up: the peer died,
    /// closed without `Goodbye`, stalled past the heartbeat deadline, or
    /// sent a malformed or oversized frame.
    #[error("{peer}: {reason}")]
    PeerLost {
        /// The peer, e.g. `worker 2 (127.0.0.1:4711)`.
        peer: String,
        /// What happened.
        reason: String,
    },
    /// Setting up a connection failed: not a pvrsim peer, wrong protocol
    /// version, wrong token, replayed or forged handshake, timeout.
    #[error("handshake with {peer}: {msg}")]
    Handshake {
        /// The peer's address or name.
        peer: String,
        /// What went wrong.
        msg: String,
    },
    /// An I/O error outside a live connection (bind, connect, token file).
    #[error("{what}: {msg}")]
    Io {
        /// What was being done.
        what: String,
        /// The error.
        msg: String,
    },
    /// A worker thread of the wall-clock driver panicked.
    #[error("actor thread for {0} panicked")]
    ThreadPanic(NodeId),
}

/// Result type of the `net` module.
pub type NetResult<T> = std::result::Result<T, NetError>;
