//! The wire form of a layer message (below [`super::exec`], which runs the
//! rounds, and [`super::rank`], one rank's steps): `u32 count`, then per
//! layer `u32 length` and its encoding under the layer codec; the receiver
//! decodes it strictly.

use crate::base::Rect;
use crate::compositor::codec::layers::{raw_bytes, LayerCodec};
use crate::compositor::codec::Limits;
use crate::compositor::region::{area, contains};

use super::Layer;

/// A layer message: `u32 count`, then per layer `u32 length` and its
/// encoding under `codec`. Returns the bytes and their raw-codec size.
pub fn encode(codec: &dyn LayerCodec, layers: &[Layer]) -> (Vec<u8>, u64) {
    let mut out = Vec::new();
    out.extend_from_slice(&(layers.len() as u32).to_le_bytes());
    let mut raw = 4u64;
    for l in layers {
        let at = out.len();
        out.extend_from_slice(&[0; 4]);
        codec.encode(l, &mut out);
        let n = (out.len() - at - 4) as u32;
        out[at..at + 4].copy_from_slice(&n.to_le_bytes());
        raw += 4 + raw_bytes(l);
    }
    (out, raw)
}

/// Decodes a message written by [`encode`], strictly (errors name the byte).
pub fn decode(codec: &dyn LayerCodec, bytes: &[u8]) -> anyhow::Result<Vec<Layer>> {
    decode_limited(codec, bytes, u32::MAX as u64)
}

/// [`decode`] with at most `max_pixels` pixels a layer.
fn decode_limited(
    codec: &dyn LayerCodec,
    bytes: &[u8],
    max_pixels: u64,
) -> anyhow::Result<Vec<Layer>> {
    let word = |at: usize| -> anyhow::Result<usize> {
        let b = bytes
            .get(at..at + 4)
            .ok_or_else(|| anyhow::anyhow!("layer message truncated at byte {at}"))?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let n = word(0)?;
    anyhow::ensure!(
        n <= bytes.len() / 4,
        "layer message: {n} layers in {} bytes",
        bytes.len()
    );
    let mut at = 4;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let len = word(at)?;
        let body = bytes
            .get(at + 4..at + 4 + len)
            .ok_or_else(|| anyhow::anyhow!("layer message truncated at byte {}", at + 4))?;
        let lim = Limits {
            max_pixels,
            ..Limits::default()
        };
        out.push(
            codec
                .decode(body, &lim)
                .map_err(|e| anyhow::anyhow!("layer at byte {}: {e}", at + 4))?,
        );
        at += 4 + len;
    }
    anyhow::ensure!(
        at == bytes.len(),
        "layer message: {} trailing bytes",
        bytes.len() - at
    );
    Ok(out)
}

/// Decodes a layer message addressed to the region `rect` (untrusted
/// bytes): at most `area(rect)` pixels a layer, every layer inside `rect`.
pub fn decode_within(
    codec: &dyn LayerCodec,
    bytes: &[u8],
    rect: &Rect,
) -> anyhow::Result<Vec<Layer>> {
    let layers = decode_limited(codec, bytes, area(rect) as u64)?;
    for l in &layers {
        anyhow::ensure!(
            contains(rect, &l.rect),
            "a layer of {:?} outside the message's region {rect:?}",
            l.rect
        );
    }
    Ok(layers)
}
