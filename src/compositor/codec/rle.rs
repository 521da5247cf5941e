//! Run-length coding of empty pixels (Maruyama et al.: a run of pixels with
//! `A = 0` becomes one 4-byte word holding the run length), generalised to
//! segment lists.
//!
//! Both payloads are a sequence of `u32` words. A word with the high bit set
//! is a run of `w & 0x7fff_ffff >= 1` empty pixels (no segments / all-zero
//! RGBA). Otherwise, for lists, `w >= 1` is the segment count of the next
//! pixel, followed by its segments; for pixels, `w >= 1` is a count of
//! literal pixels that follow. The words must cover the region exactly.

use crate::compositor::lists::{RegionLists, RegionPixels};
use crate::compositor::region::area;

use super::wire::{put_header, put_list, put_pixel, put_u32, read_list, Reader, RUN};
use super::{Codec, DecodeError, Limits, PIXEL_BYTES};

/// The run-length codec.
#[derive(Debug, Clone, Copy, Default)]
pub struct Rle;

/// Emits runs of `n` pixels where `empty(k)` holds, and calls `literal(range)`
/// for the maximal stretches in between.
fn runs(
    n: usize,
    empty: impl Fn(usize) -> bool,
    out: &mut Vec<u8>,
    mut literal: impl FnMut(&mut Vec<u8>, usize, usize),
) {
    let mut k = 0;
    while k < n {
        let mut e = k;
        while e < n && empty(e) && e - k < (RUN - 1) as usize {
            e += 1;
        }
        if e > k {
            put_u32(out, RUN | (e - k) as u32);
            k = e;
            continue;
        }
        while e < n && !empty(e) && e - k < (RUN - 1) as usize {
            e += 1;
        }
        literal(out, k, e);
        k = e;
    }
}

/// Reads the length of an empty run, checked against the pixels left.
fn run_len(rd: &Reader, w: u32, left: usize) -> Result<usize, DecodeError> {
    let len = (w & !RUN) as usize;
    if len == 0 || len > left {
        return Err(rd.error(format!("run of {len} empty pixels with {left} pixels left")));
    }
    Ok(len)
}

impl Codec for Rle {
    fn name(&self) -> &'static str {
        "rle"
    }

    fn encode_lists(&self, lists: &RegionLists, out: &mut Vec<u8>) {
        put_header(out, b'L', b'R', &lists.rect());
        runs(
            lists.pixels(),
            |p| lists.list(p).is_empty(),
            out,
            |out, a, b| {
                for p in a..b {
                    put_list(out, lists.list(p));
                }
            },
        );
    }

    fn decode_lists(&self, bytes: &[u8], limits: &Limits) -> Result<RegionLists, DecodeError> {
        let mut rd = Reader::new(bytes);
        let rect = rd.header(b'L', b'R', limits)?;
        let n = area(&rect);
        let mut start = Vec::with_capacity(n + 1);
        let mut segs = Vec::new();
        start.push(0);
        while start.len() <= n {
            let w = rd.u32()?;
            if w & RUN != 0 {
                let len = run_len(&rd, w, n + 1 - start.len())?;
                start.resize(start.len() + len, segs.len());
            } else if w == 0 {
                return Err(rd.error("zero segment count: empty pixels must be coded as runs"));
            } else {
                read_list(&mut rd, w, limits, &mut segs)?;
                start.push(segs.len());
            }
        }
        rd.finish()?;
        Ok(RegionLists::from_parts(rect, start, segs))
    }

    fn encode_pixels(&self, pixels: &RegionPixels, out: &mut Vec<u8>) {
        put_header(out, b'P', b'R', &pixels.rect);
        let px = &pixels.px;
        runs(
            px.len(),
            |k| RegionPixels::is_clear(&px[k]),
            out,
            |out, a, b| {
                put_u32(out, (b - a) as u32);
                for p in &px[a..b] {
                    put_pixel(out, p);
                }
            },
        );
    }

    fn decode_pixels(&self, bytes: &[u8], limits: &Limits) -> Result<RegionPixels, DecodeError> {
        let mut rd = Reader::new(bytes);
        let rect = rd.header(b'P', b'R', limits)?;
        let n = area(&rect);
        let mut px = Vec::with_capacity(n.min(bytes.len() / 4 + 1));
        while px.len() < n {
            let w = rd.u32()?;
            let left = n - px.len();
            if w & RUN != 0 {
                let len = run_len(&rd, w, left)?;
                px.resize(px.len() + len, Default::default());
            } else {
                let len = w as usize;
                if len == 0 || len > left {
                    return Err(rd.error(format!("{len} literal pixels with {left} pixels left")));
                }
                rd.need((PIXEL_BYTES * len) as u64)?;
                for _ in 0..len {
                    px.push(rd.pixel()?);
                }
            }
        }
        rd.finish()?;
        Ok(RegionPixels { rect, px })
    }
}
