//! The TCP transport: the same [`crate::net::Transport`] as the channel
//! transport, over authenticated TCP connections between processes or
//! machines. The protocol (preamble, handshake, frames, failure) is in
//! `src/net/README.md`.
//!
//! | file | job |
//! |---|---|
//! | [`auth`] | the shared token, HMAC-SHA256, OS randomness |
//! | [`handshake`] | preamble and two-way challenge-response |
//! | [`frame`] | link frames (data, heartbeat, goodbye), size-checked decoding |
//! | [`connect`](mod@connect) | dial and accept with timeouts; the loopback rule |
//! | [`raw`] | typed messages on a bare stream during session set-up |
//! | [`transport`] | [`TcpTransport`]: reader and writer tasks per peer, heartbeats, counting |

pub mod auth;
pub mod connect;
pub mod frame;
pub mod handshake;
pub mod raw;
pub mod transport;

pub use crate::net::remote::WireStats;
pub use auth::Token;
pub use connect::{accept, check_exposure, connect, is_loopback};
pub use frame::{decode_all, LinkFrame};
pub use handshake::{PeerHello, Role, PROTOCOL_VERSION};
pub use transport::{Link, TcpOptions, TcpTransport};

/// The process's tokio runtime for network tasks: two worker threads (the
/// rendering runs on the caller's threads).
pub fn runtime() -> crate::net::NetResult<std::sync::Arc<tokio::runtime::Runtime>> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .thread_name("pvrsim-net")
        .enable_all()
        .build()
        .map(std::sync::Arc::new)
        .map_err(|e| crate::net::NetError::Io {
            what: "starting the network runtime".into(),
            msg: e.to_string(),
        })
}
