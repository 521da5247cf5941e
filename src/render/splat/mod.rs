//! Splatting of regular grids (issue 11): every voxel is drawn as an EWA
//! Gaussian footprint, back to front, in one of the visit orders of
//! [`order`] (axis-aligned, the paper's DDA, or a full depth sort).

pub mod order;
