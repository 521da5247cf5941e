//! The 3D texture's memory layout: where the eight corners of a trilinear
//! fetch live.
//!
//! # Why tiles
//!
//! A volume stored x-fastest puts the corners of one cell on four cache
//! lines (two rows, two slabs `n_x n_y` elements apart), and a ray that is
//! not along x leaves a row after a voxel or two: on colin27 (301 x 370 x
//! 316, 35 MB, larger than the cache) half of slice3d's frame was spent
//! waiting for the first corner's load (`perf annotate`). Neighbouring rays
//! of an oblique view fall on other rows and slabs, so the lines one ray
//! brought in are rarely the next ray's. GPUs store 3D textures tiled for
//! this reason; so does the slicer here:
//!
//! ```text
//!   tile (t_x, t_y, t_z) holds samples 16 t_a .. 16 t_a + 16 on each axis
//!   (17^3 samples, 16^3 cells; neighbouring tiles share their face layer),
//!   x fastest inside the tile:  l_x + 17 l_y + 289 l_z,
//!   tiles 4928 samples apart (17^3 rounded up to 64: tiles start on a
//!   cache line for every texel size)
//! ```
//!
//! Every cell then lies inside one tile (`t_a = c_a >> 4`, `l_a = c_a & 15
//! <= 15`, so `l_a + 1 <= 16`), its eight corners are at fixed offsets
//! `{0, 1, 17, 18, 289, 290, 306, 307}` from `l_x + 17 l_y + 289 l_z`, and
//! a ray crossing a tile stays within 5 KiB (u8) that the next rays through
//! the same tile reuse. A tile is two min–max blocks
//! ([`BLOCK`](crate::render::slicing::blocks::BLOCK) = 8 cells) per axis.
//! The price is memory: `4928 / 16^3 = 1.20` times the voxels (samples past
//! the volume's last layer are padded by repeating it; they are never the
//! corner of a cell).
//!
//! Both layouts give the same corner values, so the image does not depend
//! on the layout (tested).

use rayon::prelude::*;

use crate::data::Voxels;
use crate::render::slicing::Texel;

/// Cells per tile edge (a power of two: the tile of cell `c` is `c >> 4`).
pub const TILE_CELLS: usize = 16;
/// Samples per tile edge (tiles overlap by one sample).
pub const TILE: usize = TILE_CELLS + 1;
/// Samples from one tile's start to the next's (`TILE^3` rounded up to 64).
pub const TILE_STRIDE: usize = (TILE * TILE * TILE).div_ceil(64) * 64;

/// Where the eight corners of a cell are: the fetch the samplers share.
pub trait Corners: Sync {
    /// The texel type.
    type T: Texel;
    /// The corner values of cell `c` (`c_a <= dims_a - 2`), in the order
    /// `v000, v100, v010, v110, v001, v101, v011, v111`.
    fn corners(&self, c: [usize; 3]) -> [Self::T; 8];
    /// The trilinear interpolant in cell `c` at fractions `f`.
    #[inline(always)]
    fn fetch(&self, c: [usize; 3], f: [f32; 3]) -> f32 {
        crate::render::slicing::texel::trilinear(self.corners(c).map(Texel::f), f)
    }
}

/// The volume as read: x fastest, then y, then z.
pub struct Linear<'a, T> {
    /// Voxels.
    pub data: &'a [T],
    /// Row stride (`n_x`).
    pub nx: usize,
    /// Slab stride (`n_x n_y`).
    pub nxy: usize,
}

impl<T: Copy> Linear<'_, T> {
    /// The corners of cell `c` (any element type: the pre-classified RGBA8
    /// texture too).
    #[inline(always)]
    pub fn at(&self, c: [usize; 3]) -> [T; 8] {
        let (nx, nxy) = (self.nx, self.nxy);
        let base = c[0] + nx * c[1] + nxy * c[2];
        let s = &self.data[base..base + nxy + nx + 2];
        [
            s[0],
            s[1],
            s[nx],
            s[nx + 1],
            s[nxy],
            s[nxy + 1],
            s[nxy + nx],
            s[nxy + nx + 1],
        ]
    }
}

impl<T: Texel> Corners for Linear<'_, T> {
    type T = T;
    #[inline(always)]
    fn corners(&self, c: [usize; 3]) -> [T; 8] {
        self.at(c)
    }
    #[inline(always)]
    fn fetch(&self, c: [usize; 3], f: [f32; 3]) -> f32 {
        let base = c[0] + self.nx * c[1] + self.nxy * c[2];
        T::trilinear(&self.data[base..], self.nx, self.nxy, f)
    }
}

/// The volume in overlapping 16^3 tiles (see the module docs).
pub struct Tiled<'a, T> {
    /// Tiles, each `TILE^3` samples (then padding to `TILE_STRIDE`), tile x
    /// fastest.
    pub data: &'a [T],
    /// Tiles per axis.
    pub nt: [usize; 3],
}

impl<T: Texel> Tiled<'_, T> {
    /// Index of the first corner of cell `c`.
    #[inline(always)]
    fn base(&self, c: [usize; 3]) -> usize {
        let t = c.map(|x| x / TILE_CELLS);
        let l = c.map(|x| x % TILE_CELLS);
        let tile = (t[2] * self.nt[1] + t[1]) * self.nt[0] + t[0];
        tile * TILE_STRIDE + l[0] + TILE * l[1] + TILE * TILE * l[2]
    }
}

impl<T: Texel> Corners for Tiled<'_, T> {
    type T = T;
    #[inline(always)]
    fn fetch(&self, c: [usize; 3], f: [f32; 3]) -> f32 {
        T::trilinear(&self.data[self.base(c)..], TILE, TILE * TILE, f)
    }
    #[inline(always)]
    fn corners(&self, c: [usize; 3]) -> [T; 8] {
        let t = c.map(|x| x / TILE_CELLS);
        let l = c.map(|x| x % TILE_CELLS);
        let tile = (t[2] * self.nt[1] + t[1]) * self.nt[0] + t[0];
        let base = tile * TILE_STRIDE + l[0] + TILE * l[1] + TILE * TILE * l[2];
        const R: usize = TILE;
        const S: usize = TILE * TILE;
        let s = &self.data[base..base + S + R + 2];
        [
            s[0],
            s[1],
            s[R],
            s[R + 1],
            s[S],
            s[S + 1],
            s[S + R],
            s[S + R + 1],
        ]
    }
}

/// An owned tiled copy of a volume's voxels (the "uploaded" 3D texture).
pub struct TiledVoxels {
    /// The tiles' samples, in the volume's own type.
    pub voxels: Voxels,
    /// Tiles per axis.
    pub nt: [usize; 3],
}

/// Tiles per axis for `dims` samples (at least one).
pub fn tile_counts(dims: [u64; 3]) -> [usize; 3] {
    dims.map(|n| ((n.max(2) - 1) as usize).div_ceil(TILE_CELLS).max(1))
}

impl TiledVoxels {
    /// Copies `voxels` (`dims` samples, x fastest) into tiles.
    pub fn new(voxels: &Voxels, dims: [u64; 3]) -> TiledVoxels {
        let nt = tile_counts(dims);
        let voxels = match voxels {
            Voxels::U8(v) => Voxels::U8(tile(v, dims, nt)),
            Voxels::U16(v) => Voxels::U16(tile(v, dims, nt)),
            Voxels::I16(v) => Voxels::I16(tile(v, dims, nt)),
            Voxels::F32(v) => Voxels::F32(tile(v, dims, nt)),
        };
        TiledVoxels { voxels, nt }
    }
}

/// The tiled copy of `data`.
fn tile<T: Texel + Default>(data: &[T], dims: [u64; 3], nt: [usize; 3]) -> Vec<T> {
    let d = dims.map(|x| x as usize);
    let (nx, nxy) = (d[0], d[0] * d[1]);
    let mut out = vec![T::default(); nt[0] * nt[1] * nt[2] * TILE_STRIDE];
    out.par_chunks_mut(TILE_STRIDE)
        .enumerate()
        .for_each(|(i, dst)| {
            let t = [i % nt[0], (i / nt[0]) % nt[1], i / (nt[0] * nt[1])];
            let lo = t.map(|x| x * TILE_CELLS);
            for lz in 0..TILE {
                let z = (lo[2] + lz).min(d[2] - 1);
                for ly in 0..TILE {
                    let y = (lo[1] + ly).min(d[1] - 1);
                    let row = &mut dst[TILE * (ly + TILE * lz)..][..TILE];
                    let src = &data[nxy * z + nx * y..][..nx];
                    // The row's samples inside the volume, then the last one
                    // repeated.
                    let inside = TILE.min(nx - lo[0]);
                    row[..inside].copy_from_slice(&src[lo[0]..lo[0] + inside]);
                    let last = src[nx - 1];
                    row[inside..].fill(last);
                }
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Both layouts give every cell the same eight corners.
        #[test]
        fn tiled_corners_equal_linear(
            dims in prop::array::uniform3(2u64..40),
            seed in any::<u64>(),
        ) {
            let n = (dims[0] * dims[1] * dims[2]) as usize;
            let mut x = seed | 1;
            let data: Vec<u16> = (0..n)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    x as u16
                })
                .collect();
            let tv = TiledVoxels::new(&Voxels::U16(data.clone()), dims);
            let Voxels::U16(tiles) = &tv.voxels else { unreachable!() };
            let lin = Linear { data: &data, nx: dims[0] as usize, nxy: (dims[0] * dims[1]) as usize };
            let til = Tiled { data: tiles, nt: tv.nt };
            for cz in 0..dims[2] as usize - 1 {
                for cy in 0..dims[1] as usize - 1 {
                    for cx in 0..dims[0] as usize - 1 {
                        prop_assert_eq!(lin.corners([cx, cy, cz]), til.corners([cx, cy, cz]));
                    }
                }
            }
        }
    }
}
