//! `rle-paper` / `rle16`: the paper's run-length code, one pixel-sized
//! word per item (see the module docs of [`super`] for the format and its
//! edge cases).

use super::{
    at_depth, check_premultiplied, put_layer_header, put_pixel, read_layer_header, read_word,
    LayerCodec,
};
use crate::compositor::codec::wire::{DecodeError, Limits, Reader};
use crate::compositor::layer_types::{Depth, Layer};
use crate::compositor::region::area;

/// The paper's RLE at a depth.
#[derive(Debug, Clone, Copy)]
pub struct Rle(pub Depth);

fn byte(depth: Depth) -> u8 {
    match depth {
        Depth::U8 => b'p',
        Depth::U16 => b'q',
    }
}

/// Longest run one word holds at `depth`: `2^(3 bits) - 1`.
pub fn max_run(depth: Depth) -> u64 {
    (1u64 << (3 * 8 * depth.channel_bytes())) - 1
}

fn put_run(out: &mut Vec<u8>, depth: Depth, mut n: u64) {
    let bits = 8 * depth.channel_bytes();
    let mask = depth.max() as u64;
    while n > 0 {
        let k = n.min(max_run(depth));
        let w = [
            (k & mask) as u16,
            (k >> bits & mask) as u16,
            (k >> (2 * bits) & mask) as u16,
            0,
        ];
        put_pixel(out, depth, &w);
        n -= k;
    }
}

impl LayerCodec for Rle {
    fn name(&self) -> &'static str {
        match self.0 {
            Depth::U8 => "rle-paper",
            Depth::U16 => "rle16",
        }
    }

    fn depth(&self) -> Depth {
        self.0
    }

    fn encode(&self, layer: &Layer, out: &mut Vec<u8>) {
        let d = self.0;
        let layer = at_depth(layer, d);
        put_layer_header(out, byte(d), &layer);
        let mut run = 0u64;
        for p in &layer.px {
            if p[3] == 0 {
                debug_assert_eq!(*p, [0; 4], "premultiplied pixel with A = 0 and RGB != 0");
                run += 1;
            } else {
                put_run(out, d, run);
                run = 0;
                put_pixel(out, d, p);
            }
        }
        put_run(out, d, run);
    }

    fn decode(&self, bytes: &[u8], limits: &Limits) -> Result<Layer, DecodeError> {
        let d = self.0;
        let pb = d.pixel_bytes();
        let bits = 8 * d.channel_bytes();
        let mut rd = Reader::new(bytes);
        let (rect, ranks) = read_layer_header(&mut rd, byte(d), limits)?;
        let n = area(&rect);
        // Every word yields at least one pixel, so no more words than pixels.
        let mut px: Vec<[u16; 4]> = Vec::with_capacity(n.min(rd.left() / pb));
        let mut short_run_before = false;
        while px.len() < n {
            let at = rd.offset();
            let w = read_word(&mut rd, d)?;
            let bad = |msg: String| DecodeError::Malformed { offset: at, msg };
            if w[3] != 0 {
                px.push(check_premultiplied(w, at)?);
                short_run_before = false;
                continue;
            }
            let k = w[0] as u64 | (w[1] as u64) << bits | (w[2] as u64) << (2 * bits);
            if k == 0 {
                return Err(bad("run of length 0".into()));
            }
            if short_run_before {
                return Err(bad(format!(
                    "run after a run shorter than {} (not canonical)",
                    max_run(d)
                )));
            }
            if k > (n - px.len()) as u64 {
                return Err(bad(format!(
                    "run of {k} pixels overruns the region ({} left)",
                    n - px.len()
                )));
            }
            px.resize(px.len() + k as usize, [0; 4]);
            short_run_before = k < max_run(d);
        }
        rd.finish()?;
        Ok(Layer {
            rect,
            ranks,
            depth: d,
            px,
        })
    }
}
