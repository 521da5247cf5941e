//! Phase 2 of the parallel renderer: compositing the nodes' ray-segment
//! lists into one image.
//!
//! Everything here is a pure function over data: no threads, no transport.
//!
//! - [`canonical`]: the canonical composition that makes the image
//!   bit-for-bit independent of how segments were spread and merged.
//! - [`lists`]: a node's lists for a region, merging, final composition.
//! - [`codec`]: compression as its own layer (`raw`, `rle`), strict decoding.
//! - [`strategy`]: strategies as schedules of rounds (`direct-send`,
//!   `binary-swap`), selected by name.
//! - [`schedule`]: the schedule data type and its validity check.
//! - [`exec`]: runs a schedule in-process, round by round, with real bytes.
//! - [`layer`]: visibility-ordered RGBA layers (grid frames), with their
//!   types in [`layer_types`] (shared with the layer codecs).
//! - [`partial`]: one rank's side of a schedule for either partial kind
//!   (lists, layers), what phase 2 worker to worker runs.
//!
//! The protocol is described in `src/compositor/README.md`.
#![warn(missing_docs)]

pub mod codec;
pub mod exec;
pub mod layer;
pub mod layer_types;
pub mod lists;
pub mod partial;
pub mod region;
pub mod schedule;
pub mod strategy;

/// The canonical composition lives in the base (the cell renderer uses it
/// for `--canonical`); re-exported here, where phase 2 relies on it.
pub use crate::base::canonical;

pub use exec::{run_local, CompositeStats, ExecError, ExecOptions, LocalRun, Message, RoundStats};
pub use lists::{RegionLists, RegionPixels};
pub use schedule::{Exchange, Payload, Round, RoundKind, Schedule};
pub use strategy::Strategy;
