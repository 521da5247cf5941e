//! `raw` / `raw16`: every pixel, 4 or 8 bytes each.

use super::{
    at_depth, put_layer_header, put_pixel, read_layer_header, read_raw_pixels, LayerCodec,
};
use crate::compositor::codec::wire::{DecodeError, Limits, Reader};
use crate::compositor::layer_types::{Depth, Layer};

/// Codec byte of raw layers at `depth`.
pub(super) fn byte(depth: Depth) -> u8 {
    match depth {
        Depth::U8 => b'8',
        Depth::U16 => b'6',
    }
}

/// Uncompressed layers at a depth.
#[derive(Debug, Clone, Copy)]
pub struct Raw(pub Depth);

/// Appends the raw encoding of a layer already at its codec's depth
/// (shared with `sparse`'s fallback).
pub(super) fn encode_raw(layer: &Layer, out: &mut Vec<u8>) {
    let d = layer.depth;
    put_layer_header(out, byte(d), layer);
    out.reserve(d.pixel_bytes() * layer.px.len());
    for p in &layer.px {
        put_pixel(out, d, p);
    }
}

/// Decodes after the magic check for [`byte`]`(depth)`.
pub(super) fn decode_raw(
    bytes: &[u8],
    limits: &Limits,
    depth: Depth,
) -> Result<Layer, DecodeError> {
    let mut rd = Reader::new(bytes);
    let (rect, ranks) = read_layer_header(&mut rd, byte(depth), limits)?;
    let px = read_raw_pixels(&mut rd, &rect, depth)?;
    rd.finish()?;
    Ok(Layer {
        rect,
        ranks,
        depth,
        px,
    })
}

impl LayerCodec for Raw {
    fn name(&self) -> &'static str {
        match self.0 {
            Depth::U8 => "raw",
            Depth::U16 => "raw16",
        }
    }

    fn depth(&self) -> Depth {
        self.0
    }

    fn encode(&self, layer: &Layer, out: &mut Vec<u8>) {
        encode_raw(&at_depth(layer, self.0), out);
    }

    fn decode(&self, bytes: &[u8], limits: &Limits) -> Result<Layer, DecodeError> {
        decode_raw(bytes, limits, self.0)
    }
}
