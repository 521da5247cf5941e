//! The second partial kind: **visibility-ordered RGBA layers** (sort-last
//! rendering of bricks, `parallel-texture-vr-rle.txt`).
//!
//! A [`Layer`] is a brick's subimage: premultiplied RGBA8 over a screen
//! rectangle, with the inclusive range `[lo, hi]` of visibility ranks it
//! covers (rank 0 is nearest the eye). A brick's own layer has `lo == hi`;
//! a merge of layers adjacent in the order (`a.hi + 1 == b.lo`) covers both.
//! Because "over" is associative, any grouping of adjacent ranks gives the
//! same image (up to rounding), so strategies may merge early only adjacent
//! ranges, and the final composite walks the ranks front to back:
//!
//! ```text
//! C = Σ_r  C_r · Π_{q<r} (1 - A_q)        (premultiplied C_r, ranks q, r)
//! ```
//!
//! The paper's master blends back to front with factors `(1, 1 - A_s)`;
//! front to back with `(1 - A_dst, 1)` is the same sum.
//!
//! Pixels are 8-bit, as the paper's subimages: quantised once per brick by
//! rounding to nearest, which is monotone, so premultiplied `RGB <= A` holds
//! after quantisation and `A = 0` implies `RGB = 0` (the codecs rely on it).

pub mod exec;

use crate::render::cell::scan::Rect;

use super::region::area;

/// One brick's (or a run of adjacent bricks') premultiplied RGBA8 subimage.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layer {
    /// The screen rectangle the pixels cover (row-major inside it).
    pub rect: Rect,
    /// Inclusive range of visibility ranks (0 = nearest the eye).
    pub ranks: [u32; 2],
    /// Premultiplied RGBA8, `area(rect)` of them.
    pub px: Vec<[u8; 4]>,
}

/// Rounds a premultiplied `[0, 1]` channel to 8 bits (nearest).
#[inline]
pub fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

impl Layer {
    /// An empty (all transparent) layer.
    pub fn empty(rect: Rect, rank: u32) -> Layer {
        Layer {
            rect,
            ranks: [rank, rank],
            px: vec![[0; 4]; area(&rect)],
        }
    }

    /// Quantises premultiplied f32 pixels (row-major over `rect`).
    pub fn quantize(rect: Rect, rank: u32, px: &[[f32; 4]]) -> Layer {
        debug_assert_eq!(px.len(), area(&rect));
        Layer {
            rect,
            ranks: [rank, rank],
            px: px.iter().map(|p| p.map(to_u8)).collect(),
        }
    }

    /// The part of the layer inside `r` (clipped to the layer's rectangle).
    pub fn crop(&self, r: &Rect) -> Layer {
        let c = intersect(&self.rect, r);
        let mut px = Vec::with_capacity(area(&c));
        let w = self.rect.width() as usize;
        for y in c.y0..c.y1 {
            let row = (y - self.rect.y0) as usize * w;
            let a = row + (c.x0 - self.rect.x0) as usize;
            let b = row + (c.x1 - self.rect.x0) as usize;
            px.extend_from_slice(&self.px[a..b]);
        }
        Layer {
            rect: c,
            ranks: self.ranks,
            px,
        }
    }

    /// Bytes of the pixels at 4 bytes each (the raw size without header).
    pub fn raw_bytes(&self) -> u64 {
        4 * self.px.len() as u64
    }
}

/// The intersection of two rectangles (empty, anchored at `a`'s corner
/// clamped into `b`, when they do not overlap).
pub fn intersect(a: &Rect, b: &Rect) -> Rect {
    let x0 = a.x0.max(b.x0);
    let y0 = a.y0.max(b.y0);
    let x1 = a.x1.min(b.x1).max(x0);
    let y1 = a.y1.min(b.y1).max(y0);
    Rect { x0, y0, x1, y1 }
}

/// Composites `layers` over `region` front to back in rank order (f32
/// accumulation); returns premultiplied RGBA without background, row-major
/// over `region`. Ranks must not overlap (checked: an `Err` names the pair).
pub fn composite(region: &Rect, layers: &[&Layer]) -> Result<Vec<[f32; 4]>, String> {
    let mut order: Vec<&Layer> = layers.to_vec();
    order.sort_by_key(|l| l.ranks[0]);
    for w in order.windows(2) {
        if w[0].ranks[1] >= w[1].ranks[0] {
            return Err(format!(
                "layers with overlapping ranks {:?} and {:?}",
                w[0].ranks, w[1].ranks
            ));
        }
    }
    let rw = region.width() as usize;
    let mut out = vec![[0f32; 4]; area(region)];
    for l in order {
        let c = intersect(&l.rect, region);
        let lw = l.rect.width() as usize;
        for y in c.y0..c.y1 {
            for x in c.x0..c.x1 {
                let s = l.px[(y - l.rect.y0) as usize * lw + (x - l.rect.x0) as usize];
                if s[3] == 0 {
                    continue;
                }
                let d = &mut out[(y - region.y0) as usize * rw + (x - region.x0) as usize];
                let t = 1.0 - d[3];
                for ch in 0..4 {
                    d[ch] += t * (s[ch] as f32 * (1.0 / 255.0));
                }
            }
        }
    }
    Ok(out)
}
