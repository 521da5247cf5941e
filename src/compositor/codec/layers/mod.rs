//! Codecs of RGBA layers ([`crate::compositor::layer::Layer`]): the
//! subimages of sort-last grid rendering, counted in bytes at the transport.
//!
//! Every message: the 24-byte header of the list codecs with kind `'Y'`,
//! then the layer's rank range `lo hi` (u32 LE): [`LAYER_HEADER_BYTES`].
//!
//! - `raw` (codec byte `'8'`): RGBA8, 4 bytes a pixel, row-major.
//! - `rle-paper` (`'p'`): the paper's run-length code, one 4-byte word per
//!   item: a pixel with `A != 0` is itself; a run of `n` pixels with `A = 0`
//!   is `[n & 0xff, n >> 8 & 0xff, n >> 16, 0]`, `1 <= n <= 2^24 - 1`; a
//!   longer run is split into words of `2^24 - 1` and a rest. Premultiplied
//!   RGBA makes `A = 0` mean `RGB = 0`, so a transparent pixel loses nothing
//!   in a run; a pixel with `A = 0` and `RGB != 0` is not premultiplied and
//!   the encoder never sees one (quantisation is monotone, see
//!   [`crate::compositor::layer`]); the decoder rejects such input anyway, as
//!   it rejects a run of length 0 and a short run followed by another run
//!   (the encoding is canonical: one byte string per layer). Worst case (a
//!   checkerboard): one word per pixel, exactly raw.
//! - `sparse` (`'s'`): IceT's active-pixel code: a u32 count of pairs, then
//!   per pair `(u32 inactive, u32 active, active pixels)`; trailing
//!   inactive pixels need no pair.
//!   Its checkerboard costs 12 bytes per 2 pixels (1.5x raw), so the
//!   encoder writes `raw` instead (codec byte `'8'`) whenever that is not
//!   larger: bounded by raw + header.
//!
//! Decoders check everything before allocating (limits, rank order `lo <=
//! hi`, runs fitting the rectangle exactly, premultiplied pixels `RGB <= A`,
//! no trailing bytes) and never panic.

mod raw8;
mod rle_paper;
mod sparse;

#[cfg(test)]
mod tests;

pub use raw8::Raw8;
pub use rle_paper::RlePaper;
pub use sparse::Sparse;

use super::wire::{put_header, DecodeError, Limits, Reader};
use crate::compositor::layer::Layer;
use crate::compositor::region::area;
use crate::render::cell::scan::Rect;

/// Header bytes of a layer message: magic, rectangle, rank range.
pub const LAYER_HEADER_BYTES: usize = super::HEADER_BYTES + 8;
/// The message kind byte of layers.
pub const KIND: u8 = b'Y';

/// A wire encoding of RGBA layers.
pub trait LayerCodec: Send + Sync {
    /// The name [`from_name`] knows it by.
    fn name(&self) -> &'static str;
    /// Appends the encoding of `layer` to `out`.
    fn encode(&self, layer: &Layer, out: &mut Vec<u8>);
    /// Decodes a layer written by [`LayerCodec::encode`].
    fn decode(&self, bytes: &[u8], limits: &Limits) -> Result<Layer, DecodeError>;
}

/// Names and one-line descriptions of the layer codecs.
pub fn list() -> &'static [(&'static str, &'static str)] {
    &[
        ("raw", "RGBA8, 4 bytes a pixel"),
        (
            "rle-paper",
            "the paper's RLE: a run of A = 0 pixels becomes one 4-byte pixel holding the run length in its first 3 bytes",
        ),
        (
            "sparse",
            "IceT's active-pixel runs (u32 inactive, u32 active, the active pixels), raw when that is smaller",
        ),
    ]
}

/// The layer codec called `name`.
pub fn from_name(name: &str) -> Result<Box<dyn LayerCodec>, String> {
    match name {
        "raw" => Ok(Box::new(Raw8)),
        "rle-paper" => Ok(Box::new(RlePaper)),
        "sparse" => Ok(Box::new(Sparse)),
        _ => Err(format!(
            "unknown codec `{name}` for RGBA layers (grid scenes); choose one of: raw, rle-paper, sparse"
        )),
    }
}

/// Size of `layer` under the raw codec: the reference of `codec_ratio`.
pub fn raw_bytes(layer: &Layer) -> u64 {
    LAYER_HEADER_BYTES as u64 + layer.raw_bytes()
}

fn put_layer_header(out: &mut Vec<u8>, codec: u8, l: &Layer) {
    put_header(out, KIND, codec, &l.rect);
    out.extend_from_slice(&l.ranks[0].to_le_bytes());
    out.extend_from_slice(&l.ranks[1].to_le_bytes());
}

/// Reads the header for `codec`; returns the rectangle and rank range.
fn read_layer_header(
    rd: &mut Reader,
    codec: u8,
    limits: &Limits,
) -> Result<(Rect, [u32; 2]), DecodeError> {
    let rect = rd.header(KIND, codec, limits)?;
    let at = rd.offset();
    let ranks = [rd.u32()?, rd.u32()?];
    if ranks[0] > ranks[1] {
        return Err(DecodeError::Malformed {
            offset: at,
            msg: format!("rank range {ranks:?} is inverted"),
        });
    }
    Ok((rect, ranks))
}

/// A premultiplied RGBA8 pixel, checked: `R, G, B <= A`.
fn read_pixel(rd: &mut Reader) -> Result<[u8; 4], DecodeError> {
    let at = rd.offset();
    let b = rd.bytes(4)?;
    let p = [b[0], b[1], b[2], b[3]];
    if p[0] > p[3] || p[1] > p[3] || p[2] > p[3] {
        return Err(DecodeError::Malformed {
            offset: at,
            msg: format!("pixel {p:?} is not premultiplied (RGB > A)"),
        });
    }
    Ok(p)
}

/// Reads `area(rect)` raw pixels.
fn read_raw_pixels(rd: &mut Reader, rect: &Rect) -> Result<Vec<[u8; 4]>, DecodeError> {
    let n = area(rect);
    rd.need(4 * n as u64)?;
    (0..n).map(|_| read_pixel(rd)).collect()
}
