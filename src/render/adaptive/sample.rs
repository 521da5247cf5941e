//! The field the adaptive renderer draws, and its samplers.
//!
//! # No cracks: interpolation across blocks
//!
//! Every block rebuilds the values `ṽ(x)` at *its own original sample
//! positions* `x` from its reduced samples (trilinear, [`super::axis`]);
//! the drawn field is the trilinear interpolation of `ṽ` between original
//! sample positions, exactly as `slice3d` interpolates `v`:
//!
//! ```text
//!   F(p) = Σ_{corners x of p's cell} w_x(p) ṽ(x),   ṽ(x) from the block holding x
//! ```
//!
//! A cell whose corners lie in two blocks (it straddles a block face)
//! interpolates *across* the face between the two blocks' values, so `F` is
//! continuous everywhere (no crack, whatever the levels of the neighbours),
//! `F = v`'s trilinear field wherever the blocks are at level 0 (the image is
//! `slice3d`'s), and the error the builder bounds, at the original sample
//! positions, is the error of the drawn field there. We chose this over
//! *sharing boundary samples* (a one-sample border copied from the
//! neighbour, as a GPU texture needs): a shared border at different levels
//! either forces the finer neighbour's face onto the coarser one's
//! interpolant (coupling blocks, so a block's error depends on its
//! neighbours' levels) or leaves a jump at the face.
//!
//! Inside one block the cell's eight corners share the block's tensor
//! weights, so the fetch is one sum over at most 3x3x3 stored samples
//! (2x2x2 at level 0, where it is `slice3d`'s fetch); a cell across a face
//! rebuilds its eight corners one by one.

use super::build::AdaptiveVolume;
use crate::render::slice3d::march::Sampler;
use crate::render::slicing::{Lut, Texel};

/// The adaptive field over the stored samples `data` (of `av.samples`).
pub struct Field<'a, T> {
    /// The blocks.
    pub av: &'a AdaptiveVolume,
    /// Stored samples in their own type.
    pub data: &'a [T],
}

impl<T: Texel> Field<'_, T> {
    #[inline(always)]
    fn block_index(&self, b: [usize; 3]) -> usize {
        (b[2] * self.av.nb[1] + b[1]) * self.av.nb[0] + b[0]
    }

    /// `ṽ` at original sample `x` (global indices).
    #[inline]
    pub fn at(&self, x: [usize; 3]) -> f32 {
        let av = self.av;
        let b: [usize; 3] = std::array::from_fn(|a| av.block_of[a][x[a]] as usize);
        let blk = &av.blocks[self.block_index(b)];
        let w: [(u32, u32, f32); 3] = std::array::from_fn(|a| {
            av.axes[blk.axis[a] as usize].weights[x[a] - blk.origin[a] as usize]
        });
        let (nx, nxy) = (blk.n[0] as usize, (blk.n[0] * blk.n[1]) as usize);
        let d = &self.data[blk.offset as usize..];
        let mut s = 0.0f32;
        for (kz, wz) in [(w[2].0, 1.0 - w[2].2), (w[2].1, w[2].2)] {
            for (ky, wy) in [(w[1].0, 1.0 - w[1].2), (w[1].1, w[1].2)] {
                let row = kz as usize * nxy + ky as usize * nx;
                let v0 = d[row + w[0].0 as usize].f();
                let v1 = d[row + w[0].1 as usize].f();
                s += wz * wy * ((v1 - v0) * w[0].2 + v0);
            }
        }
        s
    }

    /// `F` in cell `c` (corner `c`, `c + 1` per axis) at fractions `f`.
    #[inline]
    pub fn scalar(&self, c: [usize; 3], f: [f32; 3]) -> f32 {
        let av = self.av;
        let b0: [usize; 3] = std::array::from_fn(|a| av.block_of[a][c[a]] as usize);
        let b1: [usize; 3] = std::array::from_fn(|a| av.block_of[a][c[a] + 1] as usize);
        if b0 != b1 {
            // Across a block face: rebuild the eight corners.
            let v = |dx: usize, dy: usize, dz: usize| self.at([c[0] + dx, c[1] + dy, c[2] + dz]);
            let lerp = |a: f32, b: f32, t: f32| (b - a) * t + a;
            let x00 = lerp(v(0, 0, 0), v(1, 0, 0), f[0]);
            let x10 = lerp(v(0, 1, 0), v(1, 1, 0), f[0]);
            let x01 = lerp(v(0, 0, 1), v(1, 0, 1), f[0]);
            let x11 = lerp(v(0, 1, 1), v(1, 1, 1), f[0]);
            return lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2]);
        }
        let blk = &av.blocks[self.block_index(b0)];
        let (nx, nxy) = (blk.n[0] as usize, (blk.n[0] * blk.n[1]) as usize);
        if blk.level == 0 {
            // Full resolution: slice3d's own fetch (the same arithmetic,
            // so the same image where nothing is reduced).
            let local: [usize; 3] = std::array::from_fn(|a| c[a] - blk.origin[a] as usize);
            return crate::render::slice3d::sample::scalar(
                &self.data[blk.offset as usize..],
                nx,
                nxy,
                local,
                f,
            );
        }
        // Per axis: weights of at most three consecutive stored samples
        // `base, base + 1, base + 2` (the weights of x and x + 1, blended
        // by the fraction f).
        let mut base = [0usize; 3];
        let mut wt = [[0f32; 3]; 3];
        let mut cnt = [0usize; 3];
        for a in 0..3 {
            let t = &av.axes[blk.axis[a] as usize].weights;
            let x0 = c[a] - blk.origin[a] as usize;
            let (k00, k01, w0) = t[x0];
            let (k10, k11, w1) = t[x0 + 1];
            // x sitting exactly on the last centre has (k, k) while x + 1
            // extrapolates from (k - 1, k): start at the lower index.
            let k = k00.min(k10) as usize;
            base[a] = k;
            let g = 1.0 - f[a];
            wt[a][k00 as usize - k] += g * (1.0 - w0);
            wt[a][k01 as usize - k] += g * w0;
            wt[a][k10 as usize - k] += f[a] * (1.0 - w1);
            wt[a][k11 as usize - k] += f[a] * w1;
            cnt[a] = k01.max(k11) as usize - k + 1;
        }
        let d = &self.data[blk.offset as usize + base[0] + base[1] * nx + base[2] * nxy..];
        let mut s = 0.0f32;
        for (z, &wz) in wt[2][..cnt[2]].iter().enumerate() {
            for (y, &wy) in wt[1][..cnt[1]].iter().enumerate() {
                let row = &d[z * nxy + y * nx..];
                let mut sx = 0.0f32;
                for (x, &wx) in wt[0][..cnt[0]].iter().enumerate() {
                    sx += wx * row[x].f();
                }
                s += wz * wy * sx;
            }
        }
        s
    }
}

/// Post-classification with a table baked for one sample distance
/// (orthographic).
pub struct Baked<'a, T> {
    /// The field.
    pub field: Field<'a, T>,
    /// Index mapping.
    pub lut: &'a Lut,
    /// Premultiplied, corrected entries.
    pub baked: &'a [[f32; 4]],
}

impl<T: Texel> Sampler for Baked<'_, T> {
    #[inline(always)]
    fn rgba(&self, c: [usize; 3], f: [f32; 3], _k: f32) -> [f32; 4] {
        self.baked[self.lut.index(self.field.scalar(c, f))]
    }
}

/// Post-classification with the opacity corrected per ray (perspective).
pub struct Sigma<'a, T> {
    /// The field.
    pub field: Field<'a, T>,
    /// The table.
    pub lut: &'a Lut,
}

impl<T: Texel> Sampler for Sigma<'_, T> {
    #[inline(always)]
    fn rgba(&self, c: [usize; 3], f: [f32; 3], k: f32) -> [f32; 4] {
        let [r, g, b, sg] = self.lut.sigma[self.lut.index(self.field.scalar(c, f))];
        if sg == 0.0 {
            return [0.0; 4];
        }
        let a = 1.0 - (-sg * k).exp();
        [r * a, g * a, b * a, a]
    }
}
