//! The cluster with grid nodes (sort-last rendering of regular grids,
//! `parallel-texture-vr-rle.txt`): the same phase-1 driver
//! ([`super::phase1::drive`]) runs [`crate::node::grid::GridNodeActor`]s instead of cell nodes
//! and a manager; phase 2 runs the same compositing schedules over their
//! visibility-ranked RGBA layers ([`crate::compositor::layer::exec`]) and
//! replays every message on the simulated network
//! (`super::phase2::replay`).
//!
//! With a master (`--master`, the paper's setting) rank 0 renders nothing
//! and composites; ranks `1..=P` hold the bricks.
//!
//! Split as the mesh side is: [`config`] (settings), [`types`] (report
//! and outcome), [`driver`] (bricks, phase 1, phase 2), [`build`] (the
//! report), [`summary`] (the terminal text); a series' cameras are
//! [`crate::scene::orbit`]'s.

mod build;
mod config;
mod driver;
mod prepared;
mod summary;
mod types;

pub use build::report;
pub use config::GridConfig;
pub use driver::{finish, run, run_frames};
pub use prepared::{prepare, Phase1Out, Prepared};
pub use summary::summary;
pub use types::{GridMeasured, GridNodeReport, GridOutcome, GridReport};

#[cfg(test)]
mod tests;
