//! Data: the tetrahedral mesh, the regular grid (volume), their readers,
//! and the built-in demo datasets.

pub mod builtin;
pub mod dataset;
pub mod demo;
pub mod demo_ert;
pub mod demo_volume;
pub mod io;
pub mod lattice;
pub mod locality;
pub mod mesh;
pub mod partition;
pub mod quality;
pub mod volume;

pub use dataset::{data_format, read_dataset, DataFormat, Dataset};
pub use mesh::{Adjacency, Field, TetMesh, NO_NEIGHBOR};
pub use volume::{Volume, VoxelType, Voxels};
