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
        let b = BLOCK as usize;
        // Per slab of blocks (z), two passes: (1) the min/max over the
        // slab's z-range of samples, per (i, j) (a plane, row by row: a
        // tight loop the compiler vectorises); (2) per block, the min/max of
        // the plane over its (B + 1)^2 window. About 2 reads per voxel, no
        // per-voxel block arithmetic.
        let range: Vec<[f32; 2]> = (0..nb[2] as usize)
            .into_par_iter()
            .flat_map_iter(|bz| {
                let k0 = bz * b;
                let k1 = (k0 + b).min(dims[2] as usize - 1);
                let mut mn = vec![f32::INFINITY; nx * ny];
                let mut mx = vec![f32::NEG_INFINITY; nx * ny];
                for k in k0..=k1 {
                    let slab = &data[k * nx * ny..(k + 1) * nx * ny];
                    for ((lo, hi), v) in mn.iter_mut().zip(mx.iter_mut()).zip(slab) {
                        let v = v.f();
                        *lo = lo.min(v);
                        *hi = hi.max(v);
                    }
                }
                let mut out = Vec::with_capacity((nb[0] * nb[1]) as usize);
                for by in 0..nb[1] as usize {
                    let (j0, j1) = (by * b, ((by + 1) * b).min(ny - 1));
                    for bx in 0..nb[0] as usize {
                        let (i0, i1) = (bx * b, ((bx + 1) * b).min(nx - 1));
                        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                        for j in j0..=j1 {
                            let r = j * nx;
                            for i in i0..=i1 {
                                lo = lo.min(mn[r + i]);
                                hi = hi.max(mx[r + i]);
                            }
                        }
                        out.push([lo, hi]);
                    }
                }
                out
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
