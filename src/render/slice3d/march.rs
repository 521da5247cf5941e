//! One pixel's pass through the slices: sample, classify, composite, skip.
//!
//! Slicing draws slice after slice over the whole screen; since every pixel
//! composites only its own samples, the same image comes from taking, per
//! pixel, its samples on the slices in the same order — which is how the
//! CPU does it (a row of pixels at a time, cache-friendly, and early ray
//! termination per pixel is then free). The arithmetic per sample is the
//! slicer's: a 3D-texture fetch (trilinear), the classification, the
//! opacity correction, one blend.
//!
//! # Compositing
//!
//! With premultiplied sample colour `C_s = c α` and alpha `α`:
//!
//! ```text
//!   front to back:  C += (1 - A) C_s,  A += (1 - A) α      (stop at A >= threshold)
//!   back to front:  C  = C_s + (1 - α) C,  A = α + (1 - α) A   (blend (1, 1 - A_s))
//! ```
//!
//! # Empty-space skipping
//!
//! A sample whose cell lies in a transparent min–max block is not fetched;
//! the samples after it that lie strictly inside the cube of blocks around
//! it that are all transparent (its leap distance, a chessboard distance
//! transform of the classified blocks) are skipped with it: one step leaps
//! over many empty blocks. In an opaque block the samples up to its faces
//! are taken in a tight loop without block look-ups.
//! (Plain `a * b + c`, not `mul_add`: without a target FMA unit `mul_add`
//! is a library call, ten times slower.) Positions are always `start + k step`, never accumulated, so skipping
//! does not move the samples: the image is the same as without skipping.

use super::planes::RaySamples;
use crate::render::slicing::blocks::{leap_distances, BLOCK};
use crate::render::slicing::{clamp_fast, clamped_index, Order, SampleCounts};

/// The 3D texture as the march sees it: fetch + classify one sample.
pub trait Sampler {
    /// Premultiplied, opacity-corrected RGBA of the sample in cell `c` at
    /// fractions `f` (in `[0, 1]`), for a sample distance of `k_ud` unit
    /// distances.
    fn rgba(&self, c: [usize; 3], f: [f32; 3], k_ud: f32) -> [f32; 4];
}

/// Grid and block geometry of the march.
pub struct Grid<'a> {
    /// The last grid coordinate per axis (`dims - 1`), as f32 once: a
    /// usize-to-f32 conversion is a multi-instruction sequence on x86-64.
    pub hi: [f32; 3],
    /// Blocks per axis.
    pub nb: [usize; 3],
    /// Per block: any opacity (false = skip).
    pub opaque: &'a [bool],
    /// Per block: chessboard distance in blocks to the nearest opaque one
    /// ([`leap_distances`]; 0 = opaque), for leaping over empty space.
    pub leap: Vec<u8>,
    /// Early-termination threshold (>= 1: off).
    pub ert: f32,
}

impl<'a> Grid<'a> {
    /// The geometry of a grid of `dims` samples (at least 2 per axis) in
    /// `nb` min–max blocks whose opacity is `opaque`; `ert` >= 1 is off.
    /// Computes the leap distances (part of the classification: linear in
    /// the block count).
    pub fn new(dims: [u64; 3], nb: [usize; 3], opaque: &'a [bool], ert: f32) -> Grid<'a> {
        Grid {
            hi: dims.map(|n| (n - 1) as f32),
            nb,
            opaque,
            leap: leap_distances(opaque, nb),
            ert,
        }
    }
}

/// Whole sample steps (of `step`, from grid position `p`) that stay
/// strictly inside the cube of blocks `b ± r` (cells `[B (b - r), B (b +
/// r + 1))` per axis), less a margin of 1/100 step for the rounding of
/// `start + k step`; at most `remaining`.
#[inline(always)]
fn steps_inside(p: [f32; 3], step: [f32; 3], b: [usize; 3], r: usize, remaining: i64) -> i64 {
    let mut m = f32::INFINITY;
    for a in 0..3 {
        let lo = ((b[a] as i64 - r as i64) * BLOCK as i64) as f32;
        let hi = ((b[a] + r + 1) as i64 * BLOCK as i64) as f32;
        if step[a] > 0.0 {
            m = m.min((hi - p[a]) / step[a]);
        } else if step[a] < 0.0 {
            m = m.min((p[a] - lo) / -step[a]);
        }
    }
    // Truncation after max(0) is floor, without floorf (a libm call on
    // baseline x86-64).
    ((m - 1e-2).max(0.0) as i64).min(remaining)
}

/// Cell and fractions of grid position `p` (clamped into the grid whose
/// last coordinates are `hi`).
#[inline(always)]
pub(crate) fn locate(p: [f32; 3], hi: [f32; 3]) -> ([usize; 3], [f32; 3]) {
    let mut c = [0usize; 3];
    let mut f = [0f32; 3];
    for a in 0..3 {
        // A NaN position (never expected) becomes 0, not NaN.
        let x = clamp_fast(p[a], 0.0, hi[a]);
        let ci = clamped_index(x, hi[a] - 1.0);
        c[a] = ci;
        // Through i64: one conversion instruction (usize needs several).
        f[a] = x - ci as i64 as f32;
    }
    (c, f)
}

/// Composites one ray; returns premultiplied `[C, A]`.
#[inline]
pub fn march<S: Sampler>(
    s: &S,
    g: &Grid,
    r: &RaySamples,
    order: Order,
    n: &mut SampleCounts,
) -> [f32; 4] {
    let dir: i64 = match order {
        Order::FrontToBack => 1,
        Order::BackToFront => -1,
    };
    // Step in the direction of travel.
    let step = r.step.map(|x| x * dir as f32);
    let (mut k, end) = match order {
        Order::FrontToBack => (r.k_first as i64, r.k_last as i64),
        Order::BackToFront => (r.k_last as i64, r.k_first as i64),
    };
    let total = r.k_last - r.k_first + 1;
    let pos = |k: i64| {
        let kf = k as f32;
        [
            r.step[0] * kf + r.start[0],
            r.step[1] * kf + r.start[1],
            r.step[2] * kf + r.start[2],
        ]
    };
    let mut acc = [0f32; 4];
    let mut done = 0u64;
    loop {
        let p = pos(k);
        let (c, f) = locate(p, g.hi);
        let b = [
            c[0] / BLOCK as usize,
            c[1] / BLOCK as usize,
            c[2] / BLOCK as usize,
        ];
        let remaining = (end - k) * dir; // samples after this one
        let leap = g.leap[(b[2] * g.nb[1] + b[1]) * g.nb[0] + b[0]] as usize;
        // Samples after this one inside the block (opaque), or inside the
        // cube of blocks around it that are all transparent (leap >= 1).
        let extra = steps_inside(p, step, b, leap.max(1) - 1, remaining);
        if leap > 0 {
            n.skipped_empty += 1 + extra as u64;
            done += 1 + extra as u64;
            if extra >= remaining {
                break;
            }
            k += dir * (1 + extra);
            continue;
        }
        // An opaque block: this sample and the `extra` after it, without
        // block look-ups (a sample taken in a transparent block would
        // add exactly zero, so over-taking could not change the image).
        let (mut c, mut f) = (c, f);
        for j in 0..=extra {
            if j > 0 {
                k += dir;
                (c, f) = locate(pos(k), g.hi);
            }
            let [cr, cg, cb, a] = s.rgba(c, f, r.k_ud);
            n.taken += 1;
            done += 1;
            match order {
                Order::FrontToBack => {
                    let w = 1.0 - acc[3];
                    acc[0] += w * cr;
                    acc[1] += w * cg;
                    acc[2] += w * cb;
                    acc[3] += w * a;
                    if acc[3] >= g.ert {
                        n.skipped_ert += total - done;
                        return acc;
                    }
                }
                Order::BackToFront => {
                    let w = 1.0 - a;
                    acc = [
                        cr + w * acc[0],
                        cg + w * acc[1],
                        cb + w * acc[2],
                        a + w * acc[3],
                    ];
                }
            }
        }
        if extra >= remaining {
            break;
        }
        k += dir;
    }
    acc
}
