//! Preprocessing: cut the volume into blocks and halve each block while its
//! error stays under the tolerance (the paper's 適応的サンプリング, §4.2).
//!
//! # The tolerance
//!
//! The paper defines the error of a block as the squared error between the
//! original samples and the values sampled from the reduced block, and
//! uses a tolerance of 5 %, without saying what the 5 % is relative to. We
//! take it relative to the scalar range `R = r1 - r0` that the transfer
//! function spans (the scene's `data.range`, else the volume's value range),
//! on the root of the block's mean squared error:
//!
//! ```text
//!   E_B(l) = (1/|B|) Σ_{x ∈ B} (v(x) - ṽ_l(x))²,   level l accepted iff E_B(l) <= (τ R)²
//! ```
//!
//! so `τ = 0.05` means "RMS error at the block's original samples at most
//! 5 % of the range". `ṽ_l` is the field the renderer draws from the level-l
//! samples *as stored* (rounded to the voxel type; see [`super::axis`]).
//! A block is halved level after level and stops before the first level
//! whose error exceeds the bound (each level is checked against the
//! original, not against the previous level, so errors do not accumulate
//! unchecked).
//!
//! # Blocks
//!
//! `b` blocks per axis (`b^3` in all): block `i` along an axis of `N`
//! samples holds `[floor(i N / b), floor((i+1) N / b))`; the paper needs
//! `N / b` to be a power of two (OpenGL textures), we do not (the last
//! reduced sample of an axis may average fewer samples).

use std::time::Instant;

use rayon::prelude::*;

use super::axis::{max_level, split, AxisLevel};
use crate::data::{Volume, Voxels};
use crate::error::{Error, Result};
use crate::render::slicing::Texel;
use crate::with_texels;

/// One block at its chosen level.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// First original sample of the block (global index per axis).
    pub origin: [u64; 3],
    /// Original samples per axis `m`.
    pub dims: [u32; 3],
    /// Chosen level `l` (0 = full resolution).
    pub level: u32,
    /// Reduced samples per axis `ceil(m / 2^l)`.
    pub n: [u32; 3],
    /// Index of the block's first stored sample in [`AdaptiveVolume::samples`].
    pub offset: u64,
    /// Per axis, the index of its reconstruction weights in
    /// [`AdaptiveVolume::axes`].
    pub axis: [u32; 3],
    /// `[min, max]` of `ṽ` at the block's original samples; the drawn field
    /// interpolates those values, so this bounds it.
    pub range: [f32; 2],
    /// RMS error `sqrt(E_B(l))` at the chosen level, in scalar units.
    pub rms: f64,
}

/// A volume in blocks of their own resolution.
#[derive(Debug, Clone)]
pub struct AdaptiveVolume {
    /// Original samples per axis.
    pub dims: [u64; 3],
    /// Blocks per axis.
    pub nb: [usize; 3],
    /// Per axis: block boundaries (`nb + 1` sample indices).
    pub splits: [Vec<u64>; 3],
    /// Per axis, per original sample: its block index along the axis.
    pub block_of: [Vec<u32>; 3],
    /// Blocks, x fastest.
    pub blocks: Vec<Block>,
    /// Reconstruction weights shared by blocks of equal size and level.
    pub axes: Vec<AxisLevel>,
    /// Every block's stored samples, block after block (x fastest inside),
    /// in the volume's own voxel type.
    pub samples: Voxels,
    /// Tolerance `τ` (fraction of `R`).
    pub tolerance: f64,
    /// The range `R = r1 - r0` the tolerance is relative to.
    pub range: f64,
    /// Seconds spent building.
    pub build_s: f64,
    /// Bytes of the original samples.
    pub bytes_original: u64,
}

/// Voxel types that can store a reduced sample (rounded to the type).
pub trait Store: Texel {
    /// The stored value of mean `x`.
    fn store(x: f64) -> Self;
}
impl Store for u8 {
    fn store(x: f64) -> u8 {
        x.round().clamp(0.0, 255.0) as u8
    }
}
impl Store for u16 {
    fn store(x: f64) -> u16 {
        x.round().clamp(0.0, 65535.0) as u16
    }
}
impl Store for i16 {
    fn store(x: f64) -> i16 {
        x.round().clamp(-32768.0, 32767.0) as i16
    }
}
impl Store for f32 {
    fn store(x: f64) -> f32 {
        x as f32
    }
}

impl AdaptiveVolume {
    /// Builds with `R` = the volume's value range (1 for a constant volume).
    pub fn build(volume: &Volume, blocks: u64, tolerance: f64) -> Result<AdaptiveVolume> {
        let [lo, hi] = volume.value_range();
        let r = if hi > lo { hi - lo } else { 1.0 };
        Self::build_in_range(volume, blocks, tolerance, r)
    }

    /// Builds with `b = blocks` per axis and tolerance `τ` relative to `range`.
    pub fn build_in_range(
        volume: &Volume,
        blocks: u64,
        tolerance: f64,
        range: f64,
    ) -> Result<AdaptiveVolume> {
        check(blocks, tolerance)?;
        if !(range > 0.0 && range.is_finite()) {
            return Err(Error::Invalid(format!(
                "adaptive sampling: the scalar range must be finite and > 0, got {range}"
            )));
        }
        let t = Instant::now();
        let dims = volume.dims;
        let splits: [Vec<u64>; 3] = std::array::from_fn(|a| split(dims[a], blocks));
        let nb: [usize; 3] = std::array::from_fn(|a| splits[a].len() - 1);
        let block_of: [Vec<u32>; 3] = std::array::from_fn(|a| {
            let mut v = Vec::with_capacity(dims[a] as usize);
            for (i, w) in splits[a].windows(2).enumerate() {
                v.extend(std::iter::repeat_n(i as u32, (w[1] - w[0]) as usize));
            }
            v
        });
        // Reconstruction tables for every (m, l) that occurs.
        let mut keys: Vec<(usize, u32)> = Vec::new();
        for s in &splits {
            for w in s.windows(2) {
                let m = (w[1] - w[0]) as usize;
                for l in 0..=max_level(m) {
                    keys.push((m, l));
                }
            }
        }
        keys.sort_unstable();
        keys.dedup();
        let axes: Vec<AxisLevel> = keys.iter().map(|&(m, l)| AxisLevel::new(m, l)).collect();
        let axis_index = |m: usize, l: u32| -> u32 {
            // Past an axis's last level it stays at one sample.
            let l = l.min(max_level(m));
            keys.binary_search(&(m, l)).expect("table for every (m, l)") as u32
        };
        let bound2 = (tolerance * range).powi(2);
        let ids: Vec<[usize; 3]> = (0..nb[2])
            .flat_map(|z| (0..nb[1]).flat_map(move |y| (0..nb[0]).map(move |x| [x, y, z])))
            .collect();
        let (blocks, samples) = with_texels!(&volume.voxels, data => {
            let built: Vec<(Block, Vec<_>)> = ids
                .par_iter()
                .map(|&id| {
                    let origin: [u64; 3] = std::array::from_fn(|a| splits[a][id[a]]);
                    let m: [usize; 3] =
                        std::array::from_fn(|a| (splits[a][id[a] + 1] - splits[a][id[a]]) as usize);
                    reduce_block(data, dims, origin, m, bound2, &|mm, l| &axes[axis_index(mm, l) as usize])
                })
                .collect();
            let mut store = Vec::new();
            let mut blocks = Vec::with_capacity(built.len());
            for (mut b, s) in built {
                b.offset = store.len() as u64;
                b.axis = std::array::from_fn(|a| axis_index(b.dims[a] as usize, b.level));
                store.extend_from_slice(&s);
                blocks.push(b);
            }
            (blocks, wrap(store))
        });
        Ok(AdaptiveVolume {
            dims,
            nb,
            splits,
            block_of,
            blocks,
            axes,
            samples,
            tolerance,
            range,
            build_s: t.elapsed().as_secs_f64(),
            bytes_original: volume.voxels.bytes(),
        })
    }

    /// Bytes of the stored (reduced) samples.
    pub fn bytes(&self) -> u64 {
        self.samples.bytes()
    }

    /// The paper's 縮小率: stored bytes ÷ original bytes.
    pub fn size_ratio(&self) -> f64 {
        self.bytes() as f64 / self.bytes_original as f64
    }

    /// Blocks per level (index = level).
    pub fn level_histogram(&self) -> Vec<u64> {
        let top = self.blocks.iter().map(|b| b.level).max().unwrap_or(0) as usize;
        let mut h = vec![0u64; top + 1];
        for b in &self.blocks {
            h[b.level as usize] += 1;
        }
        h
    }

    /// RMS over all original samples of `v - ṽ`, in scalar units.
    pub fn rms_error(&self) -> f64 {
        let (mut s, mut n) = (0.0, 0.0);
        for b in &self.blocks {
            let c = b.dims.iter().map(|&d| d as f64).product::<f64>();
            s += b.rms * b.rms * c;
            n += c;
        }
        (s / n).sqrt()
    }
}

/// Checks the user's block count and tolerance.
pub fn check(blocks: u64, tolerance: f64) -> Result<()> {
    if blocks == 0 {
        return Err(Error::Invalid("--blocks must be >= 1".into()));
    }
    if !(tolerance >= 0.0 && tolerance.is_finite()) {
        return Err(Error::Invalid(format!(
            "--tolerance must be a finite fraction >= 0 (0.05 = 5 %), got {tolerance}"
        )));
    }
    Ok(())
}

/// Wraps stored samples of any voxel type back into [`Voxels`].
fn wrap<T: Texel>(v: Vec<T>) -> Voxels {
    let any: Box<dyn std::any::Any> = Box::new(v);
    let any = match any.downcast::<Vec<u8>>() {
        Ok(v) => return Voxels::U8(*v),
        Err(a) => a,
    };
    let any = match any.downcast::<Vec<u16>>() {
        Ok(v) => return Voxels::U16(*v),
        Err(a) => a,
    };
    let any = match any.downcast::<Vec<i16>>() {
        Ok(v) => return Voxels::I16(*v),
        Err(a) => a,
    };
    match any.downcast::<Vec<f32>>() {
        Ok(v) => Voxels::F32(*v),
        Err(_) => unreachable!("with_texels! yields u8, u16, i16 or f32"),
    }
}

/// Halves one axis of `r` (dims `n`, x fastest) with weights equal to the
/// original samples each value covers (`cover[k]`): the exact mean of the
/// 2^l cube, however the block size divides.
fn halve_axis(r: &[f64], n: [usize; 3], a: usize, cover: &[usize]) -> (Vec<f64>, [usize; 3]) {
    let mut out_n = n;
    out_n[a] = n[a].div_ceil(2);
    let mut out = vec![0.0; out_n[0] * out_n[1] * out_n[2]];
    let stride = [1, n[0], n[0] * n[1]];
    let ostride = [1, out_n[0], out_n[0] * out_n[1]];
    for z in 0..out_n[2] {
        for y in 0..out_n[1] {
            for x in 0..out_n[0] {
                let o = [x, y, z];
                let mut src = o;
                src[a] = 2 * o[a];
                let i0 = src[0] * stride[0] + src[1] * stride[1] + src[2] * stride[2];
                let c0 = cover[2 * o[a]] as f64;
                let v = if 2 * o[a] + 1 < n[a] {
                    let c1 = cover[2 * o[a] + 1] as f64;
                    (c0 * r[i0] + c1 * r[i0 + stride[a]]) / (c0 + c1)
                } else {
                    r[i0]
                };
                out[x * ostride[0] + y * ostride[1] + z * ostride[2]] = v;
            }
        }
    }
    (out, out_n)
}

/// Expands one axis of `q` (dims `n`) to the block's `m` original positions
/// with the axis's reconstruction weights.
fn expand_axis(q: &[f32], n: [usize; 3], a: usize, t: &AxisLevel) -> (Vec<f32>, [usize; 3]) {
    let mut out_n = n;
    out_n[a] = t.weights.len();
    let mut out = vec![0.0f32; out_n[0] * out_n[1] * out_n[2]];
    let stride = [1, n[0], n[0] * n[1]];
    let ostride = [1, out_n[0], out_n[0] * out_n[1]];
    for z in 0..out_n[2] {
        for y in 0..out_n[1] {
            for x in 0..out_n[0] {
                let o = [x, y, z];
                let (k0, k1, w) = t.weights[o[a]];
                let mut s = o;
                s[a] = 0;
                let base = s[0] * stride[0] + s[1] * stride[1] + s[2] * stride[2];
                let v0 = q[base + k0 as usize * stride[a]];
                let v1 = q[base + k1 as usize * stride[a]];
                out[x * ostride[0] + y * ostride[1] + z * ostride[2]] = (v1 - v0) * w + v0;
            }
        }
    }
    (out, out_n)
}

/// Reduces one block: returns it (offset and axis filled in by the caller)
/// with its stored samples.
fn reduce_block<'t, T: Store>(
    data: &[T],
    dims: [u64; 3],
    origin: [u64; 3],
    m: [usize; 3],
    bound2: f64,
    table: &dyn Fn(usize, u32) -> &'t AxisLevel,
) -> (Block, Vec<T>) {
    // The block's original samples, x fastest.
    let mut v = Vec::with_capacity(m[0] * m[1] * m[2]);
    for z in 0..m[2] as u64 {
        for y in 0..m[1] as u64 {
            let row = (origin[0] + dims[0] * (origin[1] + y + dims[1] * (origin[2] + z))) as usize;
            v.extend(data[row..row + m[0]].iter().map(|t| t.f() as f64));
        }
    }
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let top = (0..3).map(|a| max_level(m[a])).max().unwrap_or(0);
    let stored = |r: &[f64]| -> Vec<T> { r.iter().map(|&x| T::store(x)).collect() };
    let range_of = |s: &mut dyn Iterator<Item = f32>| {
        s.fold([f32::INFINITY, f32::NEG_INFINITY], |[a, b], t| {
            [a.min(t), b.max(t)]
        })
    };
    let mut best_q: Vec<T> = v.iter().map(|&x| T::store(x)).collect();
    let mut best_range = range_of(&mut best_q.iter().map(|t| t.f()));
    let mut best = (0u32, m.map(|x| x as u32), 0.0f64);
    let mut r = v.clone();
    let mut n = m;
    for l in 1..=top {
        // Level l from level l-1: halve every axis that still has > 1 sample.
        for a in 0..3 {
            if n[a] > 1 {
                let cover: Vec<usize> = (0..n[a])
                    .map(|k| super::axis::AxisLevel::cover(m[a], l - 1, k).len())
                    .collect();
                (r, n) = halve_axis(&r, n, a, &cover);
            }
        }
        let q = stored(&r);
        // ṽ_l at the block's original positions from the stored samples.
        let (e2, rng) = if hi == lo {
            // A constant block: every mean is the value itself, and the
            // weights sum to 1.
            let d = q[0].f() as f64 - lo;
            (d * d, [q[0].f(); 2])
        } else {
            let mut u: Vec<f32> = q.iter().map(|t| t.f()).collect();
            let mut un = n;
            for (a, &ma) in m.iter().enumerate() {
                (u, un) = expand_axis(&u, un, a, table(ma, l));
            }
            debug_assert_eq!(un, m);
            let e2 = v
                .iter()
                .zip(&u)
                .map(|(&a, &b)| (a - b as f64).powi(2))
                .sum::<f64>()
                / v.len() as f64;
            (e2, range_of(&mut u.iter().copied()))
        };
        if e2 > bound2 {
            break;
        }
        best_q = q;
        best_range = rng;
        best = (l, n.map(|x| x as u32), e2.sqrt());
    }
    let range = best_range;
    (
        Block {
            origin,
            dims: m.map(|x| x as u32),
            level: best.0,
            n: best.1,
            offset: 0,
            axis: [0; 3],
            range,
            rms: best.2,
        },
        best_q,
    )
}
