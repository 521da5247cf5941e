//! The 3D texture fetch and classification of one sample (the samplers the
//! march is generic over; monomorphised per voxel type).
//!
//! Trilinear interpolation in cell `c` at fractions `(fx, fy, fz)`:
//!
//! ```text
//!   s = lerp(lerp(lerp(v000, v100, fx), lerp(v010, v110, fx), fy),
//!            lerp(lerp(v001, v101, fx), lerp(v011, v111, fx), fy), fz)
//! ```
//!
//! - post-classification: `s` is interpolated, then looked up
//!   ([`Lut`]): `baked` entries (fixed sample
//!   distance: orthographic) or `σ` entries with `α = 1 - exp(-σ δ/ud)`
//!   (per-ray distance: perspective).
//! - pre-classification: the RGBA8 texture `(c o, o)` is interpolated
//!   channel by channel (the hardware's filtering of a classified texture),
//!   then `α = 1 - (1 - o)^(δ/ud)` and the colour `(c o) / o · α`.

use super::march::Sampler;
use super::texture::{Corners, Linear};
use crate::render::slicing::{Lut, Texel};

#[inline(always)]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    // Not `mul_add`: without a target FMA unit it is a slow library call.
    (b - a) * t + a
}

#[inline(always)]
fn tri(v: [f32; 8], f: [f32; 3]) -> f32 {
    let x00 = lerp(v[0], v[1], f[0]);
    let x10 = lerp(v[2], v[3], f[0]);
    let x01 = lerp(v[4], v[5], f[0]);
    let x11 = lerp(v[6], v[7], f[0]);
    lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2])
}

/// Interpolated scalar of a cell.
#[inline(always)]
pub fn scalar<T: Texel>(d: &[T], nx: usize, nxy: usize, c: [usize; 3], f: [f32; 3]) -> f32 {
    fetch(&Linear { data: d, nx, nxy }, c, f)
}

/// Interpolated scalar of cell `c` of texture `x` (any layout).
#[inline(always)]
pub fn fetch<X: Corners>(x: &X, c: [usize; 3], f: [f32; 3]) -> f32 {
    x.fetch(c, f)
}

/// Post-classification with a table baked for one sample distance.
pub struct PostBaked<'a, X> {
    /// The 3D texture.
    pub tex: X,
    /// Index mapping.
    pub lut: &'a Lut,
    /// Premultiplied, corrected entries.
    pub baked: &'a [[f32; 4]],
}

impl<X: Corners> Sampler for PostBaked<'_, X> {
    #[inline(always)]
    fn rgba(&self, c: [usize; 3], f: [f32; 3], _k: f32) -> [f32; 4] {
        self.baked[self.lut.index(fetch(&self.tex, c, f))]
    }
}

/// Post-classification with the opacity corrected per sample.
pub struct PostSigma<'a, X> {
    /// The 3D texture.
    pub tex: X,
    /// The table.
    pub lut: &'a Lut,
}

impl<X: Corners> Sampler for PostSigma<'_, X> {
    #[inline(always)]
    fn rgba(&self, c: [usize; 3], f: [f32; 3], k: f32) -> [f32; 4] {
        let [r, g, b, sg] = self.lut.sigma[self.lut.index(fetch(&self.tex, c, f))];
        if sg == 0.0 {
            return [0.0; 4];
        }
        let a = 1.0 - (-sg * k).exp();
        [r * a, g * a, b * a, a]
    }
}

/// Pre-classification: an RGBA8 texture of `(c o, o)` per voxel.
pub struct Pre<'a> {
    /// Classified voxels.
    pub rgba: &'a [[u8; 4]],
    /// Row stride.
    pub nx: usize,
    /// Slab stride.
    pub nxy: usize,
}

impl Sampler for Pre<'_> {
    #[inline(always)]
    fn rgba(&self, c: [usize; 3], f: [f32; 3], k: f32) -> [f32; 4] {
        let v = Linear {
            data: self.rgba,
            nx: self.nx,
            nxy: self.nxy,
        }
        .at(c);
        let ch = |i: usize| tri(v.map(|t| t[i] as f32), f) * (1.0 / 255.0);
        let o = ch(3);
        if o <= 0.0 {
            return [0.0; 4];
        }
        let a = crate::render::slicing::correct_opacity(o, k);
        let w = a / o;
        [ch(0) * w, ch(1) * w, ch(2) * w, a]
    }
}

/// Classifies every voxel into `(c o, o)` as RGBA8 (rounded), the texture
/// of pre-classification.
pub fn classify_voxels<T: Texel>(data: &[T], lut: &Lut) -> Vec<[u8; 4]> {
    use rayon::prelude::*;
    let q = |x: f32| (x * 255.0 + 0.5).clamp(0.0, 255.0) as u8;
    data.par_iter()
        .map(|v| {
            let e = lut.index(v.f());
            let [r, g, b, _] = lut.sigma[e];
            let o = lut.opacity[e];
            [q(r * o), q(g * o), q(b * o), q(o)]
        })
        .collect()
}
