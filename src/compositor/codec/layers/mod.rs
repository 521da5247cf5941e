//! Codecs of RGBA layers ([`crate::compositor::layer::Layer`]): the
//! subimages of sort-last grid rendering, counted in bytes at the transport.
//!
//! Every codec exists at two depths ([`Depth`]): the paper's 8 bits a
//! channel (`raw`, `rle-paper`, `sparse`) and 16 bits (`raw16`, `rle16`,
//! `sparse16`); a pixel is 4 channels, little-endian at 16 bits. `rle16`
//! is the default of grid runs: it meets the 1/255 target against
//! single-node `slice3d` (see [`crate::compositor::layer`]).
//!
//! Every message: the 24-byte header of the list codecs with kind `'Y'`,
//! then the layer's rank range `lo hi` (u32 LE): [`LAYER_HEADER_BYTES`].
//!
//! - `raw` / `raw16` (codec byte `'8'` / `'6'`): every pixel, row-major.
//! - `rle-paper` / `rle16` (`'p'` / `'q'`): the paper's run-length code, one
//!   pixel-sized word per item: a pixel with `A != 0` is itself; a run of
//!   `n` pixels with `A = 0` is one word whose R, G, B channels hold `n`
//!   (R the low channel), `1 <= n <= 2^(3 bits) - 1`; a longer run is split
//!   into full words and a rest. Premultiplied RGBA makes `A = 0` mean
//!   `RGB = 0`, so a transparent pixel loses nothing in a run; a pixel with
//!   `A = 0` and `RGB != 0` is not premultiplied and the encoder never sees
//!   one (quantisation is monotone, see [`crate::compositor::layer`]); the
//!   decoder rejects such input anyway, as it rejects a run of length 0 and
//!   a short run followed by another run (the encoding is canonical: one
//!   byte string per layer). Worst case (a checkerboard): one word per
//!   pixel, exactly raw.
//! - `sparse` / `sparse16` (`'s'` / `'S'`): IceT's active-pixel code: a u32
//!   count of pairs, then per pair `(u32 inactive, u32 active, active
//!   pixels)`; trailing inactive pixels need no pair. Its checkerboard costs
//!   more than raw, so the encoder writes raw at the same depth instead
//!   whenever that is not larger: bounded by raw + header.
//!
//! Decoders check everything before allocating (limits, rank order `lo <=
//! hi`, runs fitting the rectangle exactly, premultiplied pixels `RGB <= A`,
//! no trailing bytes) and never panic. A codec encodes layers of its own
//! depth; [`LayerCodec::encode`] converts another depth by rounding (the
//! executors quantise at the codec's depth, so they never rely on it).

mod raw;
mod rle;
mod sparse;

#[cfg(test)]
mod tests;

pub use raw::Raw;
pub use rle::Rle;
pub use sparse::Sparse;

use super::wire::{put_header, DecodeError, Limits, Reader};
use crate::base::Rect;
use crate::compositor::layer_types::{Depth, Layer};
use crate::compositor::region::area;

/// Header bytes of a layer message: magic, rectangle, rank range.
pub const LAYER_HEADER_BYTES: usize = super::HEADER_BYTES + 8;
/// The message kind byte of layers.
pub const KIND: u8 = b'Y';

/// A wire encoding of RGBA layers.
pub trait LayerCodec: Send + Sync {
    /// The name `--codec` knows it by (`compositor::codec::LayerCodecKind`).
    fn name(&self) -> &'static str;
    /// The depth of the pixels it carries.
    fn depth(&self) -> Depth;
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
            "the paper's RLE of RGBA8: a run of A = 0 pixels becomes one 4-byte pixel holding the run length in its first 3 bytes",
        ),
        (
            "sparse",
            "IceT's active-pixel runs of RGBA8 (u32 inactive, u32 active, the active pixels), raw when that is smaller",
        ),
        ("raw16", "RGBA16, 8 bytes a pixel"),
        (
            "rle16",
            "the paper's RLE at 16 bits a channel: a run of A = 0 pixels becomes one 8-byte pixel holding the run length in R, G, B (default)",
        ),
        (
            "sparse16",
            "IceT's active-pixel runs of RGBA16, raw16 when that is smaller",
        ),
    ]
}

/// Size of `layer` under the raw codec of its depth: the reference of
/// `codec_ratio`.
pub fn raw_bytes(layer: &Layer) -> u64 {
    LAYER_HEADER_BYTES as u64 + layer.raw_bytes()
}

/// `layer` at `depth` (a copy, rounded to nearest, when the depth differs).
fn at_depth(layer: &Layer, depth: Depth) -> std::borrow::Cow<'_, Layer> {
    if layer.depth == depth {
        return std::borrow::Cow::Borrowed(layer);
    }
    let mut l = Layer::quantize(layer.rect, 0, depth, &layer.to_f32());
    l.ranks = layer.ranks;
    std::borrow::Cow::Owned(l)
}

fn put_layer_header(out: &mut Vec<u8>, codec: u8, l: &Layer) {
    put_header(out, KIND, codec, &l.rect);
    out.extend_from_slice(&l.ranks[0].to_le_bytes());
    out.extend_from_slice(&l.ranks[1].to_le_bytes());
}

/// Appends one pixel at `depth` (channels little-endian).
#[inline]
fn put_pixel(out: &mut Vec<u8>, depth: Depth, p: &[u16; 4]) {
    match depth {
        Depth::U8 => out.extend_from_slice(&p.map(|c| c as u8)),
        Depth::U16 => {
            for c in p {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
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

/// One pixel-sized word at `depth`, unchecked.
#[inline]
fn read_word(rd: &mut Reader, depth: Depth) -> Result<[u16; 4], DecodeError> {
    let b = rd.bytes(depth.pixel_bytes())?;
    Ok(match depth {
        Depth::U8 => [b[0], b[1], b[2], b[3]].map(u16::from),
        Depth::U16 => [0, 1, 2, 3].map(|i| u16::from_le_bytes([b[2 * i], b[2 * i + 1]])),
    })
}

/// Checks premultiplication: `R, G, B <= A`.
fn check_premultiplied(p: [u16; 4], at: usize) -> Result<[u16; 4], DecodeError> {
    if p[0] > p[3] || p[1] > p[3] || p[2] > p[3] {
        return Err(DecodeError::Malformed {
            offset: at,
            msg: format!("pixel {p:?} is not premultiplied (RGB > A)"),
        });
    }
    Ok(p)
}

/// A premultiplied pixel at `depth`, checked: `R, G, B <= A`.
fn read_pixel(rd: &mut Reader, depth: Depth) -> Result<[u16; 4], DecodeError> {
    let at = rd.offset();
    check_premultiplied(read_word(rd, depth)?, at)
}

/// Reads `area(rect)` raw pixels at `depth`.
fn read_raw_pixels(
    rd: &mut Reader,
    rect: &Rect,
    depth: Depth,
) -> Result<Vec<[u16; 4]>, DecodeError> {
    let n = area(rect);
    rd.need((depth.pixel_bytes() * n) as u64)?;
    (0..n).map(|_| read_pixel(rd, depth)).collect()
}
