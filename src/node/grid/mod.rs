//! The grid node kind (sort-last rendering of regular grids,
//! `parallel-texture-vr-rle.txt`): a node holds some of the whole volume's
//! `d^3` bricks and renders each into a visibility-ranked RGBA layer, the
//! partial image the compositor's layer path takes.
//!
//! - [`bricks`]: cutting into bricks with one-voxel overlap, screen
//!   rectangles, visibility order, placement (round robin, balanced).
//! - [`render`]: one brick into one layer through a renderer of
//!   `slice3d::render`'s shape.
//! - [`cache`]: the bricks' textures kept across frames.
//! - [`device`]: the modelled time (fill rate, texture memory, uploads).
//! - [`actor`]: the node as an actor under the cluster's phase-1 driver.

pub mod actor;
pub mod bricks;
pub mod cache;
pub mod device;
pub mod render;

#[cfg(test)]
pub(crate) mod tests;

pub use actor::{GridNodeActor, GridNodeStats};
pub use bricks::{Brick, BrickPlacement};
