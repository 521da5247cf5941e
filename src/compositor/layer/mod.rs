//! The second partial kind: **visibility-ordered RGBA layers** (sort-last
//! rendering of bricks, `parallel-texture-vr-rle.txt`).
//!
//! A [`Layer`] is a brick's subimage: premultiplied fixed-point RGBA (8 or
//! 16 bits a channel) over a screen rectangle, with the inclusive range
//! `[lo, hi]` of visibility ranks it covers (rank 0 is nearest the eye). A
//! brick's own layer has `lo == hi`; a merge of layers adjacent in the order
//! (`a.hi + 1 == b.lo`) covers both.
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
//! Pixels are fixed point at a [`Depth`]: 8 bits as the paper's subimages,
//! or 16 bits, the default of grid runs (8-bit layers miss the 1/255 target
//! against single-node `slice3d`: each layer's rounding by up to 1/2 of
//! 1/255 adds up through "over", measured 1.39/255 at `d = 2`; at 16 bits the
//! same sum is at most `(3d - 2) / 257` of 1/255). A value `q` stands for
//! `q / M` with `M = 2^bits - 1`. Quantised once per brick by rounding to
//! nearest, which is monotone, so premultiplied `RGB <= A` holds after
//! quantisation and `A = 0` implies `RGB = 0` (the codecs rely on it).

pub mod exec;
pub mod message;
pub mod rank;

use crate::base::Rect;

pub use super::layer_types::{intersect, to_u8, Depth, Layer};
use super::region::area;

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
        let inv = 1.0 / l.depth.max() as f32;
        for y in c.y0..c.y1 {
            for x in c.x0..c.x1 {
                let s = l.px[(y - l.rect.y0) as usize * lw + (x - l.rect.x0) as usize];
                if s[3] == 0 {
                    continue;
                }
                let d = &mut out[(y - region.y0) as usize * rw + (x - region.x0) as usize];
                let t = 1.0 - d[3];
                for ch in 0..4 {
                    d[ch] += t * (s[ch] as f32 * inv);
                }
            }
        }
    }
    Ok(out)
}

/// Composites every run of layers whose rank ranges chain (`a.hi + 1 ==
/// b.lo`) into one layer covering the run's ranks, over the bounding box of
/// the run's rectangles, quantised at the run's depth (one rounding, at most
/// `1/2` of `1/M` a channel, per merge). Layers that chain with nothing are
/// kept as they are. Returns the layers (sorted by rank) and the pixels
/// blended. Overlapping ranks are an error, as in [`composite`].
pub fn merge_adjacent(mut layers: Vec<Layer>) -> Result<(Vec<Layer>, u64), String> {
    layers.sort_by_key(|l| l.ranks[0]);
    let mut out: Vec<Layer> = Vec::with_capacity(layers.len());
    let mut blended = 0u64;
    let mut i = 0;
    while i < layers.len() {
        let mut j = i + 1;
        while j < layers.len() && layers[j - 1].ranks[1] + 1 == layers[j].ranks[0] {
            j += 1;
        }
        if j - i == 1 {
            out.push(layers[i].clone());
        } else {
            let run = &layers[i..j];
            let depth = run[0].depth;
            if run.iter().any(|l| l.depth != depth) {
                return Err("layers of different depths cannot be merged".into());
            }
            let bbox = run.iter().skip(1).fold(run[0].rect, |a, l| Rect {
                x0: a.x0.min(l.rect.x0),
                y0: a.y0.min(l.rect.y0),
                x1: a.x1.max(l.rect.x1),
                y1: a.y1.max(l.rect.y1),
            });
            let refs: Vec<&Layer> = run.iter().collect();
            let px = composite(&bbox, &refs)?;
            blended += run.iter().map(|l| l.px.len() as u64).sum::<u64>();
            let mut m = Layer::quantize(bbox, run[0].ranks[0], depth, &px);
            m.ranks[1] = run[j - i - 1].ranks[1];
            out.push(m);
        }
        i = j;
    }
    Ok((out, blended))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn rect() -> impl Strategy<Value = Rect> {
        (0u32..20, 0u32..20, 0u32..12, 0u32..12).prop_map(|(x0, y0, w, h)| Rect {
            x0,
            y0,
            x1: x0 + w,
            y1: y0 + h,
        })
    }

    proptest! {
        /// Cropping keeps exactly the pixels inside both rectangles, even
        /// when they do not overlap (never out of bounds).
        #[test]
        fn crop_keeps_the_pixels_inside_both(a in rect(), r in rect()) {
            let px: Vec<[u16; 4]> = (0..area(&a) as u16).map(|i| [i, i, i, i]).collect();
            let l = Layer { rect: a, ranks: [0, 0], depth: Depth::U16, px };
            let c = l.crop(&r);
            prop_assert_eq!(c.px.len(), area(&c.rect));
            let mut k = 0;
            for y in a.y0..a.y1 {
                for x in a.x0..a.x1 {
                    let inside = x >= r.x0 && x < r.x1 && y >= r.y0 && y < r.y1;
                    let v = ((y - a.y0) * a.width() + (x - a.x0)) as u16;
                    if inside {
                        prop_assert_eq!(c.px[k], [v; 4]);
                        k += 1;
                    }
                }
            }
            prop_assert_eq!(k, c.px.len());
        }
    }
}
