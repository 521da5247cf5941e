//! The computational core of one cluster node (paper §2.2, §3.2, §4.3), with
//! no network: everything here is a state machine that a discrete-event
//! simulator, a thread or a TCP server can drive the same way, and the time
//! a node reports to its driver is modelled (operation counts through the
//! [`cost`] model, or the grid device model), never read from a clock.
//!
//! Clocks are read for statistics only: the grid node
//! ([`grid::GridNodeActor`]) times its render with `Instant::now()` and the
//! thread/process CPU clocks of [`crate::net::cpu`] (`GridNodeStats`'
//! `host_s`, `cpu_s`, `process_cpu_s`, `minor_faults`), which never feed the
//! modelled seconds; the mesh node's renderer reads no clock (`pvrsim
//! calibrate` times it from outside). I/O is limited to reading cost
//! profiles ([`cost::CostProfile::load`]); [`placement`] cuts the mesh with
//! rayon.
//!
//! - [`placement`]: the initial placement of cells on `N` nodes (recursive
//!   coordinate bisection or a Morton-curve cut), and its screen footprints.
//! - [`work`]: the [`WorkUnit`] that travels (initial placement and dynamic
//!   load balancing): cells with the vertex data they need, encoded with
//!   bincode and validated strictly when decoded.
//! - [`renderer`]: the [`NodeRenderer`], scan conversion in steps with early
//!   ray termination on the paper's global `D x D` table, reporting
//!   operation counts ([`ops`]).
//! - [`table`]: the [`SharedTable`] that travels between a node and the
//!   manager (1 bit + one depth per entry), and [`manager_table`]: the
//!   manager's merge rule.
//! - [`levels`] and [`pixel_share`]: ERT information that composes across
//!   nodes (opacity levels per block, or per pixel for the pyramid);
//!   [`shard_map`]: which manager shard owns which screen tile.
//! - [`schedule`]: a global front-to-back schedule over the placement
//!   (replicated data: waves of depth, each split evenly over the nodes).
//! - [`actor`]: the [`NodeActor`], phase 1 of a cluster node as a
//!   [`crate::net::Actor`] (scan in chunks, weak ERT sharing, DLB).
//! - [`cost`]: the compute-time cost model, operation counts → seconds.
//! - [`replica`]: replicated data: the whole mesh on every node, cell ids
//!   that travel instead of cells ([`IdUnit`]).
//! - [`union`]: a reference composition of all nodes' lists (for tests and
//!   checks; the real compositor is `src/compositor/`).

pub mod actor;
pub mod calibration;
pub mod cost;
pub mod grid;
pub mod levels;
pub mod lsq;
pub mod manager_table;
pub mod ops;
pub mod piece_map;
pub mod pixel_share;
pub mod placement;
pub mod protocol;
pub mod release;
pub mod renderer;
pub mod replica;
pub mod schedule;
pub mod shard_map;
pub mod table;
pub mod union;
pub mod work;

pub use actor::{NodeActor, NodeConfig, NodePolicy, NodeStats};
pub use cost::{compute_time, CostProfile};
pub use manager_table::merge_tables;
pub use ops::OpCounts;
pub use placement::{Placement, PlacementMethod};
pub use renderer::{NodeOptions, NodeRenderer, StepReport};
pub use replica::{DataMode, IdUnit, Replica};
pub use table::SharedTable;
pub use work::{WorkError, WorkUnit};
