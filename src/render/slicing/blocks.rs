//! Min–max blocks for empty-space skipping.
//!
//! Block `b = (bx, by, bz)` covers the voxel cells `[B b, B b + B)` on each
//! axis (`B` = [`BLOCK`]), that is the samples `[B b, B b + B]` (the cells'
//! corners, clamped to the grid). Its `[min, max]` is taken over those
//! samples, so every value the trilinear (or bilinear) interpolant takes
//! inside the block lies in it, and a block whose whole interval is
//! transparent under the transfer function contributes nothing (exactly, for
//! post-classification; for pre-classification the interpolated opacity is
//! a convex combination of corner opacities that are all zero).

use rayon::prelude::*;

use super::{Lut, Texel};

/// Cells per block edge.
pub const BLOCK: u64 = 8;

/// Per-block scalar range of a volume (independent of the transfer function).
#[derive(Debug, Clone)]
pub struct MinMaxBlocks {
    /// Blocks along x, y, z.
    pub nb: [u64; 3],
    /// `[min, max]` per block, x fastest.
    pub range: Vec<[f32; 2]>,
}

impl MinMaxBlocks {
    /// Scans the samples once (blocks in parallel over z slabs).
    pub fn new<T: Texel>(data: &[T], dims: [u64; 3]) -> MinMaxBlocks {
        let nb: [u64; 3] = std::array::from_fn(|a| (dims[a] - 1).div_ceil(BLOCK).max(1));
        let (nx, ny) = (dims[0] as usize, dims[1] as usize);
        let range: Vec<[f32; 2]> = (0..nb[2])
            .into_par_iter()
            .flat_map_iter(|bz| {
                let mut slab = vec![[f32::INFINITY, f32::NEG_INFINITY]; (nb[0] * nb[1]) as usize];
                let k0 = bz * BLOCK;
                let k1 = (k0 + BLOCK).min(dims[2] - 1);
                for k in k0..=k1 {
                    for j in 0..dims[1] {
                        // Sample j belongs to blocks j / B and, on a block
                        // boundary, (j / B) - 1 too.
                        let row = &data[(k as usize * ny + j as usize) * nx..][..nx];
                        let bys = block_span(j, nb[1]);
                        for i in 0..dims[0] {
                            let v = row[i as usize].f();
                            for bx in block_span(i, nb[0]) {
                                for by in bys.clone() {
                                    let r = &mut slab[(by * nb[0] + bx) as usize];
                                    r[0] = r[0].min(v);
                                    r[1] = r[1].max(v);
                                }
                            }
                        }
                    }
                }
                slab
            })
            .collect();
        MinMaxBlocks { nb, range }
    }

    /// Per block: does the transfer function give it any opacity?
    pub fn opaque(&self, lut: &Lut) -> Vec<bool> {
        self.range
            .iter()
            .map(|&[lo, hi]| !lut.transparent(lo, hi))
            .collect()
    }
}

/// Blocks `b` that hold sample `i`: `B b <= i <= B b + B`, `b < nb`
/// (one block, or two on a block boundary).
fn block_span(i: u64, nb: u64) -> std::ops::Range<u64> {
    let first = if i >= BLOCK {
        (i - BLOCK).div_ceil(BLOCK)
    } else {
        0
    };
    let last = (i / BLOCK).min(nb - 1);
    first..last + 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Every block's range is exactly the min and max of its samples.
        #[test]
        fn ranges_are_exact(dims in proptest::array::uniform3(2u64..20), seed in 0u64..1000) {
            let n = (dims[0] * dims[1] * dims[2]) as usize;
            let data: Vec<f32> = (0..n).map(|i| ((i as u64 * 2654435761 + seed) % 1000) as f32).collect();
            let mm = MinMaxBlocks::new(&data, dims);
            for bz in 0..mm.nb[2] { for by in 0..mm.nb[1] { for bx in 0..mm.nb[0] {
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for k in bz * BLOCK..=((bz + 1) * BLOCK).min(dims[2] - 1) {
                    for j in by * BLOCK..=((by + 1) * BLOCK).min(dims[1] - 1) {
                        for i in bx * BLOCK..=((bx + 1) * BLOCK).min(dims[0] - 1) {
                            let v = data[(i + dims[0] * (j + dims[1] * k)) as usize];
                            lo = lo.min(v); hi = hi.max(v);
                        }
                    }
                }
                let r = mm.range[((bz * mm.nb[1] + by) * mm.nb[0] + bx) as usize];
                prop_assert_eq!(r, [lo, hi]);
            }}}
        }
    }
}
