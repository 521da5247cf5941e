//! Data: the tetrahedral mesh, its readers, and the built-in demo dataset.

pub mod mesh;

pub use mesh::{Adjacency, Field, TetMesh, NO_NEIGHBOR};
