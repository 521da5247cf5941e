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

/// Chessboard (L-infinity) distance, in blocks, from every block to the
/// nearest block that is not transparent, capped at 255: 0 for an opaque
/// block, `d >= 1` when every block `b'` with `max_a |b'_a - b_a| < d` is
/// transparent (blocks outside the grid count as transparent: no sample is
/// taken there). Two raster passes over the 26-neighbourhood with unit
/// weights (Rosenfeld and Pfaltz 1966), exact for this metric: each pass
/// propagates along every monotone path, and a chessboard-shortest path
/// can always be split into one forward and one backward monotone part.
/// Linear in the number of blocks (colin27: 71 000 blocks, well under a
/// millisecond), so it is redone with the classification on every
/// transfer-function change.
pub fn leap_distances(opaque: &[bool], nb: [usize; 3]) -> Vec<u8> {
    let [nx, ny, nz] = nb;
    debug_assert_eq!(opaque.len(), nx * ny * nz);
    let mut d: Vec<u8> = opaque.iter().map(|&o| if o { 0 } else { 255 }).collect();
    let idx = |x: usize, y: usize, z: usize| (z * ny + y) * nx + x;
    // Forward: neighbours earlier in raster order (z, then y, then x).
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let i = idx(x, y, z);
                if d[i] == 0 {
                    continue;
                }
                let mut m = d[i];
                for dz in -1i64..=0 {
                    for dy in -1i64..=1 {
                        for dx in -1i64..=1 {
                            // The 13 causal neighbours.
                            if dz == 0 && (dy > 0 || (dy == 0 && dx >= 0)) {
                                continue;
                            }
                            let (xx, yy, zz) = (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                            if xx < 0 || yy < 0 || zz < 0 || xx >= nx as i64 || yy >= ny as i64 {
                                continue;
                            }
                            let v = d[idx(xx as usize, yy as usize, zz as usize)];
                            m = m.min(v.saturating_add(1));
                        }
                    }
                }
                d[i] = m;
            }
        }
    }
    // Backward: the mirrored 13.
    for z in (0..nz).rev() {
        for y in (0..ny).rev() {
            for x in (0..nx).rev() {
                let i = idx(x, y, z);
                if d[i] == 0 {
                    continue;
                }
                let mut m = d[i];
                for dz in 0i64..=1 {
                    for dy in -1i64..=1 {
                        for dx in -1i64..=1 {
                            if dz == 0 && (dy < 0 || (dy == 0 && dx <= 0)) {
                                continue;
                            }
                            let (xx, yy, zz) = (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                            if xx < 0
                                || yy < 0
                                || xx >= nx as i64
                                || yy >= ny as i64
                                || zz >= nz as i64
                            {
                                continue;
                            }
                            let v = d[idx(xx as usize, yy as usize, zz as usize)];
                            m = m.min(v.saturating_add(1));
                        }
                    }
                }
                d[i] = m;
            }
        }
    }
    d
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

    proptest! {
        /// The leap distance is the brute-force chessboard distance to the
        /// nearest opaque block (capped at 255).
        #[test]
        fn leap_distances_are_exact(nb in proptest::array::uniform3(1usize..9), seed in 0u64..1000, fill in 0u64..40) {
            let n = nb[0] * nb[1] * nb[2];
            let opaque: Vec<bool> = (0..n).map(|i| (i as u64 * 2654435761 + seed * 97) % 100 < fill).collect();
            let d = leap_distances(&opaque, nb);
            for z in 0..nb[2] { for y in 0..nb[1] { for x in 0..nb[0] {
                let mut best = 255usize;
                for zz in 0..nb[2] { for yy in 0..nb[1] { for xx in 0..nb[0] {
                    if opaque[(zz * nb[1] + yy) * nb[0] + xx] {
                        let c = x.abs_diff(xx).max(y.abs_diff(yy)).max(z.abs_diff(zz));
                        best = best.min(c);
                    }
                }}}
                prop_assert_eq!(d[(z * nb[1] + y) * nb[0] + x] as usize, best);
            }}}
        }
    }
}
