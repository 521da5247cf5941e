//! Data: the tetrahedral mesh, its readers, and the built-in demo dataset.

pub mod demo;
pub mod io;
pub mod lattice;
pub mod mesh;
pub mod quality;
pub mod volume;

pub use mesh::{Adjacency, Field, TetMesh, NO_NEIGHBOR};
pub use volume::{Volume, VoxelType, Voxels};
