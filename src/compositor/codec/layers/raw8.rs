//! `raw`: RGBA8, 4 bytes a pixel.

use super::{put_layer_header, read_layer_header, read_raw_pixels, LayerCodec};
use crate::compositor::codec::wire::{DecodeError, Limits, Reader};
use crate::compositor::layer::Layer;

/// Codec byte of raw layers.
pub(super) const BYTE: u8 = b'8';

/// Uncompressed RGBA8 layers.
#[derive(Debug, Clone, Copy, Default)]
pub struct Raw8;

/// Appends the raw encoding (shared with `sparse`'s fallback).
pub(super) fn encode_raw(layer: &Layer, out: &mut Vec<u8>) {
    put_layer_header(out, BYTE, layer);
    out.reserve(4 * layer.px.len());
    for p in &layer.px {
        out.extend_from_slice(p);
    }
}

/// Decodes after the magic check for [`BYTE`].
pub(super) fn decode_raw(bytes: &[u8], limits: &Limits) -> Result<Layer, DecodeError> {
    let mut rd = Reader::new(bytes);
    let (rect, ranks) = read_layer_header(&mut rd, BYTE, limits)?;
    let px = read_raw_pixels(&mut rd, &rect)?;
    rd.finish()?;
    Ok(Layer { rect, ranks, px })
}

impl LayerCodec for Raw8 {
    fn name(&self) -> &'static str {
        "raw"
    }

    fn encode(&self, layer: &Layer, out: &mut Vec<u8>) {
        encode_raw(layer, out);
    }

    fn decode(&self, bytes: &[u8], limits: &Limits) -> Result<Layer, DecodeError> {
        decode_raw(bytes, limits)
    }
}
