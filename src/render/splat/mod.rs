//! Splatting of regular grids (issue 11): every voxel is drawn as an EWA
//! Gaussian footprint, back to front, in one of the visit orders of
//! [`order`] (axis-aligned, the paper's DDA, or a full depth sort).
//!
//! - [`classify`]: per-sample extinction and colour, threshold culling;
//! - [`footprint`]: the EWA projection and the opacity contract;
//! - [`order`]: the visit orders;
//! - [`raster`]: one footprint into a band of rows (exact, incremental);
//! - [`composite`]: back to front / front to back, early splat elimination;
//! - [`bands`]: the banded rasterising phase;
//! - [`table`]: tabulated footprints at sub-pixel phases (orthographic);
//! - [`mem`]: huge pages for the frame's large buffers;
//! - [`render`]: the frame (order + project, then banded rasterising).

pub mod bands;
pub mod buffer;
pub mod classify;
pub mod composite;
pub mod footprint;
pub mod mem;
pub mod order;
pub mod project;
pub mod raster;
pub mod record;
pub mod render;
pub mod table;

#[cfg(test)]
mod tests;

pub use render::{render_splat, SplatOptions, SplatStats};
