//! `rle-paper`: the 4-byte run-length code of the paper (see the module
//! docs of [`super`] for the format and its edge cases).

use super::{put_layer_header, read_layer_header, LayerCodec};
use crate::compositor::codec::wire::{DecodeError, Limits, Reader};
use crate::compositor::layer::Layer;
use crate::compositor::region::area;

const BYTE: u8 = b'p';
/// Longest run one word holds: `2^24 - 1`.
pub const MAX_RUN: u32 = (1 << 24) - 1;

/// The paper's RLE of RGBA8 layers.
#[derive(Debug, Clone, Copy, Default)]
pub struct RlePaper;

fn put_run(out: &mut Vec<u8>, mut n: u32) {
    while n > 0 {
        let k = n.min(MAX_RUN);
        out.extend_from_slice(&[k as u8, (k >> 8) as u8, (k >> 16) as u8, 0]);
        n -= k;
    }
}

impl LayerCodec for RlePaper {
    fn name(&self) -> &'static str {
        "rle-paper"
    }

    fn encode(&self, layer: &Layer, out: &mut Vec<u8>) {
        put_layer_header(out, BYTE, layer);
        let mut run = 0u32;
        for p in &layer.px {
            if p[3] == 0 {
                debug_assert_eq!(*p, [0; 4], "premultiplied pixel with A = 0 and RGB != 0");
                run += 1;
            } else {
                put_run(out, run);
                run = 0;
                out.extend_from_slice(p);
            }
        }
        put_run(out, run);
    }

    fn decode(&self, bytes: &[u8], limits: &Limits) -> Result<Layer, DecodeError> {
        let mut rd = Reader::new(bytes);
        let (rect, ranks) = read_layer_header(&mut rd, BYTE, limits)?;
        let n = area(&rect);
        // Every word yields at least one pixel, so no more words than pixels.
        let mut px: Vec<[u8; 4]> = Vec::with_capacity(n.min(rd.left() / 4));
        let mut short_run_before = false;
        while px.len() < n {
            let at = rd.offset();
            let b = rd.bytes(4)?;
            let w = [b[0], b[1], b[2], b[3]];
            let bad = |msg: String| DecodeError::Malformed { offset: at, msg };
            if w[3] != 0 {
                if w[0] > w[3] || w[1] > w[3] || w[2] > w[3] {
                    return Err(bad(format!("pixel {w:?} is not premultiplied (RGB > A)")));
                }
                px.push(w);
                short_run_before = false;
                continue;
            }
            let k = w[0] as u32 | (w[1] as u32) << 8 | (w[2] as u32) << 16;
            if k == 0 {
                return Err(bad("run of length 0".into()));
            }
            if short_run_before {
                return Err(bad(
                    "run after a run shorter than 2^24 - 1 (not canonical)".into()
                ));
            }
            if k as usize > n - px.len() {
                return Err(bad(format!(
                    "run of {k} pixels overruns the region ({} left)",
                    n - px.len()
                )));
            }
            px.resize(px.len() + k as usize, [0; 4]);
            short_run_before = k < MAX_RUN;
        }
        rd.finish()?;
        Ok(Layer { rect, ranks, px })
    }
}
