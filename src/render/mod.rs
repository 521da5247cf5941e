//! Renderers. Each algorithm lives in its own module; this module holds only
//! what they share: the prepared input (mesh + normalised scalars + scene).
//!
//! - [`cell`]: cell projection with ray-segment lists and partial composition
//!   (the paper's renderer; the fast path).
//! - [`reference`]: f64 ray walking through the mesh with adaptive quadrature
//!   (the oracle; shares nothing with `cell` but the scene and TF types).

pub mod cell;
pub mod input;
pub mod reference;
pub mod splat;

pub use input::RenderInput;
