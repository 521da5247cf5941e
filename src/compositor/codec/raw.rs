//! No compression: per pixel a `u32` segment count and the segments; pixels
//! as four `f32` each.

use crate::compositor::lists::{RegionLists, RegionPixels};
use crate::compositor::region::area;

use super::wire::{put_header, put_list, put_pixel, read_list, Reader};
use super::{Codec, DecodeError, Limits, PIXEL_BYTES};

/// The raw codec.
#[derive(Debug, Clone, Copy, Default)]
pub struct Raw;

impl Codec for Raw {
    fn name(&self) -> &'static str {
        "raw"
    }

    fn encode_lists(&self, lists: &RegionLists, out: &mut Vec<u8>) {
        put_header(out, b'L', b'r', &lists.rect());
        for p in 0..lists.pixels() {
            put_list(out, lists.list(p));
        }
    }

    fn decode_lists(&self, bytes: &[u8], limits: &Limits) -> Result<RegionLists, DecodeError> {
        let mut rd = Reader::new(bytes);
        let rect = rd.header(b'L', b'r', limits)?;
        let n = area(&rect);
        rd.need(4 * n as u64)?;
        let mut start = Vec::with_capacity(n + 1);
        let mut segs = Vec::new();
        start.push(0);
        for _ in 0..n {
            let count = rd.u32()?;
            read_list(&mut rd, count, limits, &mut segs)?;
            start.push(segs.len());
        }
        rd.finish()?;
        Ok(RegionLists::from_parts(rect, start, segs))
    }

    fn encode_pixels(&self, pixels: &RegionPixels, out: &mut Vec<u8>) {
        put_header(out, b'P', b'r', &pixels.rect);
        for p in &pixels.px {
            put_pixel(out, p);
        }
    }

    fn decode_pixels(&self, bytes: &[u8], limits: &Limits) -> Result<RegionPixels, DecodeError> {
        let mut rd = Reader::new(bytes);
        let rect = rd.header(b'P', b'r', limits)?;
        let n = area(&rect);
        rd.need((PIXEL_BYTES * n) as u64)?;
        let px = (0..n).map(|_| rd.pixel()).collect::<Result<Vec<_>, _>>()?;
        rd.finish()?;
        Ok(RegionPixels { rect, px })
    }
}
