//! `sparse` / `sparse16`: IceT's active-pixel runs, or raw at the same
//! depth when that is not larger (see the module docs of [`super`]).

use super::raw::{byte as raw_byte, decode_raw, encode_raw};
use super::{
    at_depth, put_layer_header, put_pixel, read_layer_header, read_pixel, LayerCodec,
    LAYER_HEADER_BYTES,
};
use crate::compositor::codec::wire::{put_u32, DecodeError, Limits, Reader};
use crate::compositor::layer_types::{Depth, Layer};
use crate::compositor::region::area;

/// IceT-style sparse layers with a raw fallback, at a depth.
#[derive(Debug, Clone, Copy)]
pub struct Sparse(pub Depth);

fn byte(depth: Depth) -> u8 {
    match depth {
        Depth::U8 => b's',
        Depth::U16 => b'S',
    }
}

/// `(inactive, active)` runs of `px`; a trailing inactive run gets no pair.
fn runs(px: &[[u16; 4]]) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    let mut i = 0usize;
    while i < px.len() {
        let s = i;
        while i < px.len() && px[i][3] == 0 {
            i += 1;
        }
        let a = i;
        while i < px.len() && px[i][3] != 0 {
            i += 1;
        }
        if i > a {
            out.push(((a - s) as u32, (i - a) as u32));
        }
    }
    out
}

impl LayerCodec for Sparse {
    fn name(&self) -> &'static str {
        match self.0 {
            Depth::U8 => "sparse",
            Depth::U16 => "sparse16",
        }
    }

    fn depth(&self) -> Depth {
        self.0
    }

    fn encode(&self, layer: &Layer, out: &mut Vec<u8>) {
        let d = self.0;
        let pb = d.pixel_bytes();
        let layer = at_depth(layer, d);
        let runs = runs(&layer.px);
        let active: usize = runs.iter().map(|r| r.1 as usize).sum();
        let sparse = 4 + 8 * runs.len() + pb * active;
        if sparse >= pb * layer.px.len() {
            encode_raw(&layer, out);
            return;
        }
        out.reserve(LAYER_HEADER_BYTES + sparse);
        put_layer_header(out, byte(d), &layer);
        put_u32(out, runs.len() as u32);
        let mut i = 0usize;
        for (z, a) in runs {
            put_u32(out, z);
            put_u32(out, a);
            i += z as usize;
            for p in &layer.px[i..i + a as usize] {
                put_pixel(out, d, p);
            }
            i += a as usize;
        }
    }

    fn decode(&self, bytes: &[u8], limits: &Limits) -> Result<Layer, DecodeError> {
        let d = self.0;
        let pb = d.pixel_bytes();
        let rd0 = Reader::new(bytes);
        if rd0.peek_at(3) == Some(raw_byte(d)) {
            return decode_raw(bytes, limits, d);
        }
        let mut rd = Reader::new(bytes);
        let (rect, ranks) = read_layer_header(&mut rd, byte(d), limits)?;
        let n = area(&rect);
        let pairs = rd.u32()? as u64;
        // Each pair is at least two words and a pixel.
        rd.need((8 + pb as u64) * pairs)?;
        let mut px: Vec<[u16; 4]> = Vec::with_capacity(n.min(rd.left() / pb));
        for _ in 0..pairs {
            let at = rd.offset();
            let z = rd.u32()? as usize;
            let a = rd.u32()? as usize;
            let bad = |msg: String| DecodeError::Malformed { offset: at, msg };
            if a == 0 {
                return Err(bad("run pair with no active pixel".into()));
            }
            if z > n - px.len() || a > n - px.len() - z {
                return Err(bad(format!(
                    "runs ({z} inactive, {a} active) overrun the region ({} left)",
                    n - px.len()
                )));
            }
            if !px.is_empty() && z == 0 {
                return Err(bad("two active runs in a row (not canonical)".into()));
            }
            rd.need((pb * a) as u64)?;
            px.resize(px.len() + z, [0; 4]);
            for _ in 0..a {
                let at = rd.offset();
                let p = read_pixel(&mut rd, d)?;
                if p[3] == 0 {
                    return Err(DecodeError::Malformed {
                        offset: at,
                        msg: "inactive pixel (A = 0) inside an active run".into(),
                    });
                }
                px.push(p);
            }
        }
        rd.finish()?;
        px.resize(n, [0; 4]);
        // Canonical: the encoder sends raw whenever sparse is not smaller.
        if rd.offset() - LAYER_HEADER_BYTES >= pb * n {
            return Err(DecodeError::Malformed {
                offset: LAYER_HEADER_BYTES,
                msg: "sparse encoding not smaller than raw (the encoder would send raw)".into(),
            });
        }
        Ok(Layer {
            rect,
            ranks,
            depth: d,
            px,
        })
    }
}
