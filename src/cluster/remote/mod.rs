//! Real transports for a cluster run: worker processes on this machine
//! (`--transport processes`), on other machines (`--transport tcp`) or
//! under `mpirun` (`--transport mpi`), the coordinator running the manager. The node, manager and compositor code
//! is the same as under the simulator and the threads; only the driver and
//! the transport change.
//!
//! | file | job |
//! |---|---|
//! | [`accept`] | a worker's door: authenticated sessions and peers |
//! | [`hooks`] | a worker's test hooks (kill or stop itself mid-frame) |
//! | [`session`] | set-up and result messages, wire forms of the options |
//! | [`compare`] | measured traffic beside the virtual model's for the same frame |
//! | [`coordinator`] | the TCP coordinator: connect, set-up, cells |
//! | [`live`] | a session: workers connected once, a frame per call, `End` |
//! | [`engine`] | a session's nodes on TCP links or MPI ranks, driven alike |
//! | [`drive`] | the coordinator's frame over any [`crate::net::RemoteTransport`]: manager, results, phase 2 |
//! | [`grid`] | grid scenes: bricks to workers (cached), layers to the master |
//! | [`grid_wire`] | a grid worker's set-up and the bricks' samples as bytes |
//! | [`guard`] | keeps session messages away from the actors; failure reports become errors |
//! | [`phase2`] | compositing worker to worker: one rank's rounds, the coordinator's gather |
//! | [`measured`] | what a real transport measured beside the report |
//! | [`pieces`] | partitioned data: each worker reads its own pieces of a `.pvtu` |
//! | [`mesh`] | a worker joins the mesh of its peers; its transport with the coordinator's link |
//! | [`worker`] | `pvrsim worker`: sessions, one node |
//! | `mpi` | (feature `mpi`) `--transport mpi`: a session on MPI ranks, rank 0 the coordinator; ranks read their own pieces |
//! | [`reassign`] | `--on-failure reassign`: lost workers' cells to the survivors, the frame again |
//! | [`spawn`] | child worker processes on loopback, reaped on every path |
//! | [`probe`] | the echo service for `pvrsim calibrate --network` |

pub mod accept;
pub mod compare;
pub mod coordinator;
pub mod drive;
pub mod engine;
pub mod grid;
pub mod grid_wire;
pub mod guard;
pub mod hooks;
pub mod live;
pub mod measured;
pub mod mesh;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod phase2;
pub mod pieces;
pub mod probe;
pub mod reassign;
pub mod session;
pub mod spawn;
pub mod worker;

pub use compare::{transport_section, TransportSection};
pub use coordinator::Coordinator;
pub use engine::LiveNodes;
pub use live::{LiveCluster, Work};
pub use measured::Measured;
pub use spawn::LocalWorkers;
pub use worker::Worker;
