//! The communication substrate: typed messages, a transport interface, a
//! network cost model and a deterministic discrete-event simulator.
//!
//! | file | job |
//! |---|---|
//! | [`message`] | ranks, message kinds, envelopes, size-limited bincode codec |
//! | [`transport`] | the [`Transport`] trait (send / recv / try_recv, rank, size) and selective receive |
//! | [`channel`] | in-process transport on crossbeam channels |
//! | [`metered`] | counts messages and bytes per kind and destination at the boundary |
//! | [`cost`] | the network cost model (alpha-beta + NIC serialisation + bisection) and presets |
//! | [`cpu`] | thread and process CPU clocks; modelled-vs-measured compute samples |
//! | [`clock`] | virtual and wall clocks, the (time, seq) event queue |
//! | [`actor`] | the [`Actor`] state-machine interface shared by both drivers |
//! | [`sim`] | the discrete-event driver (virtual time, one thread) |
//! | [`wall`] | the thread driver (wall time, real transports) |
//! | [`remote`] | [`RemoteTransport`]: what the remote drivers need beyond [`Transport`]; [`WireStats`] |
//! | [`tcp`] | the TCP transport: token handshake, frames, heartbeats, per-peer tasks |
//! | `mpi` | (feature `mpi`) the MPI transport: one MPI thread per process, ranks from `mpirun` |
//! | [`trace`] | typed timeline and Chrome trace JSON |
//!
//! Node and manager logic is written once against [`Actor`]; the design
//! notes are in `src/net/README.md`.

pub mod actor;
pub mod channel;
pub mod clock;
pub mod cost;
pub mod cpu;
pub mod error;
mod inbox;
pub mod message;
pub mod metered;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod names;
pub mod remote;
pub mod sim;
pub mod stall;
pub mod tcp;
pub mod trace;
pub mod transport;
pub mod wall;

#[cfg(test)]
mod tests;

pub use actor::{Action, Activity, Actor, Event};
pub use channel::{ChannelNetwork, ChannelTransport};
pub use clock::{Clock, EventQueue, VirtualClock, WallClock};
pub use cost::{NetState, NetworkModel, Transfer};
pub use error::{NetError, NetResult};
pub use message::{
    Codec, Envelope, Message, MessageKind, NodeId, DEFAULT_MAX_MESSAGE_BYTES, FRAME_HEADER_BYTES,
};
pub use metered::{Counter, Metered, TrafficStats};
pub use remote::{RemoteTransport, WireStats};
pub use sim::{SimOptions, SimReport, Simulation};
pub use trace::{SimTrace, TraceEvent, TraceKind};
pub use transport::{Mailbox, Transport};
pub use wall::{run_actor, run_threads, ComputeMode, WallOptions, WallReport};
