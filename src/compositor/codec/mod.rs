//! Compression as its own layer: a [`Codec`] turns segment-list regions and
//! pixel regions into bytes and back. Compositing calls only this interface
//! and never looks inside the bytes.
//!
//! Decoding treats the bytes as untrusted (they come from peers): every size
//! is checked against the remaining input and against [`Limits`] before
//! anything is allocated, every float must be finite, depths ordered, alpha
//! in `[0, 1]`, lists in canonical order; any violation is a [`DecodeError`]
//! naming the byte offset. Decoding never panics.
//!
//! Every message starts with an 8-byte magic and a 16-byte rectangle:
//!
//! ```text
//! 'P' 'V' kind codec 0 0 0 version   x0 y0 x1 y1 (u32 LE)
//! kind: 'L' lists, 'P' pixels; codec: 'r' raw, 'R' rle; version 1
//! ```

mod kind;
pub mod layers;
mod raw;
mod rle;
pub(crate) mod wire;

pub use kind::{LayerCodecKind, ListCodecKind};
pub use raw::Raw;
pub use rle::Rle;
pub use wire::{DecodeError, Limits};

use super::lists::{RegionLists, RegionPixels};

/// Bytes of the message header (magic + rectangle).
pub const HEADER_BYTES: usize = 24;
/// Bytes of one segment on the wire (six `f32`).
pub const SEGMENT_BYTES: usize = 24;
/// Bytes of one pixel on the wire (four `f32`).
pub const PIXEL_BYTES: usize = 16;

/// A wire encoding of regions.
pub trait Codec: Send + Sync {
    /// The name [`from_name`] knows it by.
    fn name(&self) -> &'static str;
    /// Appends the encoding of `lists` to `out`.
    fn encode_lists(&self, lists: &RegionLists, out: &mut Vec<u8>);
    /// Decodes lists encoded by [`Codec::encode_lists`].
    fn decode_lists(&self, bytes: &[u8], limits: &Limits) -> Result<RegionLists, DecodeError>;
    /// Appends the encoding of `pixels` to `out`.
    fn encode_pixels(&self, pixels: &RegionPixels, out: &mut Vec<u8>);
    /// Decodes pixels encoded by [`Codec::encode_pixels`].
    fn decode_pixels(&self, bytes: &[u8], limits: &Limits) -> Result<RegionPixels, DecodeError>;
}

/// Names and one-line descriptions of every codec.
pub fn list() -> &'static [(&'static str, &'static str)] {
    &[
        ("raw", "no compression: per pixel a segment count and the segments (lists), or four f32 (pixels)"),
        (
            "rle",
            "runs of empty pixels (no segments / all-zero RGBA) collapse into one 4-byte word (Maruyama et al.'s scheme, generalised to segment lists)",
        ),
    ]
}

/// The codec called `name` (a [`ListCodecKind`]'s name).
pub fn from_name(name: &str) -> Result<Box<dyn Codec>, String> {
    Ok(name.parse::<ListCodecKind>()?.build())
}

/// The layer codec called `name` (a [`LayerCodecKind`]'s name).
pub fn layer_codec(name: &str) -> Result<Box<dyn layers::LayerCodec>, String> {
    Ok(name.parse::<LayerCodecKind>()?.build())
}

/// Size of `lists` under the raw codec: the "uncompressed" reference.
pub fn raw_lists_bytes(lists: &RegionLists) -> u64 {
    (HEADER_BYTES + 4 * lists.pixels() + SEGMENT_BYTES * lists.segments().len()) as u64
}

/// Segments in lists of `pixels` pixels whose raw encoding takes
/// `raw_bytes` (the inverse of [`raw_lists_bytes`]).
pub fn raw_lists_segments(raw_bytes: u64, pixels: u64) -> u64 {
    raw_bytes.saturating_sub(HEADER_BYTES as u64 + 4 * pixels) / SEGMENT_BYTES as u64
}

/// Size of `pixels` under the raw codec.
pub fn raw_pixels_bytes(pixels: &RegionPixels) -> u64 {
    (HEADER_BYTES + PIXEL_BYTES * pixels.px.len()) as u64
}

#[cfg(test)]
mod tests;
