//! Renderers. Each algorithm lives in its own module; this module holds only
//! what they share: the prepared input (mesh + normalised scalars + scene).
//!
//! - [`cell`]: cell projection with ray-segment lists and partial composition
//!   (the paper's renderer; the fast path).
//! - [`reference`](mod@reference): f64 ray walking through the mesh with adaptive quadrature
//!   (the oracle; shares nothing with `cell` but the scene and TF types).
//! - [`grid_reference`]: the f64 oracle for regular grids (DDA through the
//!   voxel cells, the cubic along the ray, adaptive quadrature).
//! - [`slice3d`]: view-aligned texture slicing in software (trilinear).
//! - [`slice2d`]: object-aligned slicing (bilinear) with per-slice LOD.
//! - [`shearwarp`]: shear-warp factorisation over run-length encoded slices.
//! - [`splat`]: EWA splatting of regular grids in axis, DDA or sorted order.

pub mod adaptive;
pub mod cell;
pub mod coarse;
pub mod gauss;
pub mod grid_reference;
pub mod input;
pub mod reference;
pub mod shearwarp;
pub mod slice2d;
pub mod slice3d;
pub mod slicing;
pub mod splat;
pub mod volume_input;

pub use input::RenderInput;
pub use volume_input::VolumeInput;
