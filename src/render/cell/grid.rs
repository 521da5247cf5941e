//! The screen's tiles as a grid: which tiles a pixel range touches, with
//! the divisions by the tile size done as multiplications.

use crate::base::Rect;

/// Splits a `width x height` image into `tile x tile` rectangles, row-major.
pub fn tiles(width: u32, height: u32, tile: u32) -> Vec<Rect> {
    tiles_rect(width, height, tile, tile)
}

/// Splits a `width x height` image into `tw x th` rectangles, row-major
/// (early ray termination aligns tiles to its table entries).
pub fn tiles_rect(width: u32, height: u32, tw: u32, th: u32) -> Vec<Rect> {
    let mut out = Vec::new();
    for y0 in (0..height).step_by(th as usize) {
        for x0 in (0..width).step_by(tw as usize) {
            out.push(Rect {
                x0,
                y0,
                x1: (x0 + tw).min(width),
                y1: (y0 + th).min(height),
            });
        }
    }
    out
}

/// The tiles a pixel range touches, found by multiplying with reciprocals
/// (the binning asks twice per surviving cell, and an integer division is
/// tens of cycles).
#[derive(Debug, Clone, Copy)]
pub struct TileGrid {
    /// `ceil(2^32 / tw)`.
    inv_w: u64,
    /// `ceil(2^32 / th)`.
    inv_h: u64,
    /// Tiles in a row.
    tiles_x: u32,
}

impl TileGrid {
    /// The grid of `tw x th` tiles, `tiles_x` to a row (row-major).
    pub fn new(tw: u32, th: u32, tiles_x: u32) -> TileGrid {
        TileGrid {
            inv_w: reciprocal(tw),
            inv_h: reciprocal(th),
            tiles_x,
        }
    }

    /// Calls `f(first, end)` with the tile indices `first..end` of each
    /// row of tiles that the inclusive pixel range `r = [i0, i1, j0, j1]`
    /// touches, top row first.
    #[inline(always)]
    pub fn for_each_row(&self, r: [u32; 4], mut f: impl FnMut(usize, usize)) {
        let (tx0, tx1) = (quotient(r[0], self.inv_w), quotient(r[1], self.inv_w));
        let (ty0, ty1) = (quotient(r[2], self.inv_h), quotient(r[3], self.inv_h));
        let mut row = ty0 * self.tiles_x;
        for _ in ty0..ty1 + 1 {
            f((row + tx0) as usize, (row + tx1) as usize + 1);
            row += self.tiles_x;
        }
    }
}

impl TileGrid {
    /// The tile holding pixel `(i, j)`.
    #[inline(always)]
    pub fn tile_of(&self, i: u32, j: u32) -> usize {
        (quotient(j, self.inv_h) * self.tiles_x + quotient(i, self.inv_w)) as usize
    }
}

/// `ceil(2^32 / d)` for `d >= 1`: `quotient(x, reciprocal(d)) == x / d` for
/// every `x < 2^16` (the error `m d - 2^32 < d` times `x < 2^16` stays
/// below `2^32 / d`'s spacing), and pixel indices are below `2^16`.
fn reciprocal(d: u32) -> u64 {
    (1u64 << 32).div_ceil(u64::from(d.max(1)))
}

/// `x / d` for `x < 2^16`, `m = reciprocal(d)`.
#[inline(always)]
fn quotient(x: u32, m: u64) -> u32 {
    debug_assert!(x <= u16::MAX as u32);
    ((u64::from(x) * m) >> 32) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn quotient_divides_every_pixel_index_by_small_tiles() {
        for d in (1..=300).chain([512, 1000, 4096, 65535, 65536, 1 << 20, u32::MAX]) {
            let m = reciprocal(d);
            for x in 0..=u16::MAX as u32 {
                assert_eq!(quotient(x, m), x / d, "{x} / {d}");
            }
        }
    }

    proptest! {
        /// The rows handed out are the tiles `tiles_rect` makes that
        /// intersect the range, each once.
        #[test]
        fn rows_cover_the_tiles_a_range_touches(
            (w, h) in (1u32..3000, 1u32..3000),
            (tw, th) in (1u32..200, 1u32..200),
            r in (0u32..3000, 0u32..3000, 0u32..3000, 0u32..3000),
        ) {
            let (i0, i1) = ((r.0 % w).min(r.1 % w), (r.0 % w).max(r.1 % w));
            let (j0, j1) = ((r.2 % h).min(r.3 % h), (r.2 % h).max(r.3 % h));
            let rects = tiles_rect(w, h, tw, th);
            let grid = TileGrid::new(tw, th, w.div_ceil(tw));
            let mut got = Vec::new();
            grid.for_each_row([i0, i1, j0, j1], |a, b| got.extend(a..b));
            let want: Vec<usize> = rects
                .iter()
                .enumerate()
                .filter(|(_, t)| t.x0 <= i1 && i0 < t.x1 && t.y0 <= j1 && j0 < t.y1)
                .map(|(k, _)| k)
                .collect();
            prop_assert_eq!(got, want);
        }
    }
}
