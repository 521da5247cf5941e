//! The base types every layer above shares: rectangles of pixels, ray
//! segments with their premultiplied colour and the "over" operator, and the
//! canonical composition that makes a set of segments one pixel value
//! whatever order they arrived in.
//!
//! Nothing here imports another room: renderers produce these values, the
//! compositor and the cluster exchange and combine them.

pub mod cancel;
pub mod canonical;
pub mod pages;
pub mod rect;
pub mod segment;

pub use rect::Rect;
pub use segment::{touches, Rgba, Segment};
