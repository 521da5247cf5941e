//! The run report (`--report run.json`). Keys scripts rely on: `frame_s`,
//! `tsc_max_s`, `tsc_mean_s`, `imbalance`, `share_s_total`, `composite_s`,
//! `bytes_total`, `bytes_by_kind`, `t_share`, `share_efficiency`,
//! `ideal_speedup`, `nodes[]`. Host-time measurements, which vary from run
//! to run, are under `wall` only; in virtual-clock mode everything else is a
//! deterministic function of the inputs. In wall-clock mode **every** time
//! key holds a host measurement, never a modelled one (one report, one
//! clock): phase 1 from the threads' timeline, phase 2 the in-process
//! compositor's host time (all nodes' work on one thread, so per-node
//! `composite_s` is `null`), the manager's busy time from its spans, the
//! sequential reference measured on one thread; `network` and `profile`
//! then read `n/a (wall clock)`, since neither model is used for a time.
//!
//! Terms (also printed by [`summary`]):
//! - **Tsc**: a node's scan-conversion time, the end of its last scan chunk
//!   in phase 1 (no compositing); `tsc_max_s` is the slowest node's, the
//!   paper's Table 2 figure.
//! - **speed-up (Tsc)** `speedup` = sequential ÷ Tsc max; **speed-up
//!   (frame)** `speedup_frame` = sequential ÷ frame (phase 1 + phase 2):
//!   what a user waits for. The sequential run is one node holding every
//!   cell, same ERT settings, same clock.
//! - **ideal speed-up** = Base Tsc max ÷ (sequential ÷ N): the speed-up over
//!   Base (ERT, sharing, DLB off at the same N) of a cluster that skipped as
//!   much as the sequential ERT run and split it perfectly.
//! - **share efficiency** = cells skipped by ERT on all nodes ÷ cells
//!   skipped by the sequential run (1: the cluster skips as much as one
//!   machine that sees every cell).
//!
//! Files: `types.rs` holds the report's records ([`ClusterReport`],
//! [`NodeReport`], the raw per-node numbers, replication cost), `build.rs`
//! computes a report from a run's pieces, `summary.rs` prints it,
//! `series.rs` holds a frame series' section.

mod build;
pub mod cpu;
pub mod series;
mod summary;
pub mod transport;
mod types;

pub use build::{build, Inputs};
pub use summary::summary;
pub use types::{ClusterReport, NodeRaw, NodeReport, References, Replication, TShare, WallInfo};
