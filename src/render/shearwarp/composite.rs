//! Compositing the voxel slices into the intermediate image (the "shear"
//! half of shear-warp), front to back with "over", premultiplied f32 RGBA.
//!
//! Each intermediate scanline `v` is independent of the others (its rays
//! stay in it in sheared object space), so bands of [`BAND`] scanlines go
//! to the threads; a band meets the slices one after the other, front to
//! back (Lacroute's object order within the band). In slice
//! `k` it samples cell scanline `j = v + ⌊o_j⌋` at the slice's constant
//! fractions (`o = ` [`Factor::slice_offset`]), pixel `u` the cell
//! `i = u + ⌊o_i⌋`: only cells in the slice's non-transparent runs
//! ([`super::rle`]) are visited, and of those only pixels that are not yet
//! opaque, found through the scanline's **skip links** (Lacroute's opaque
//! pixel runs): `next[u] = u` for a pixel still open, else a pointer to a
//! later one, followed with path compression.

use super::factor::Factor;
use super::rle::AxisRle;
use crate::render::slicing::{Lut, SampleCounts, Texel};

/// The per-slice constants of one frame.
#[derive(Debug, Clone, Copy)]
pub struct SliceStep {
    /// The slice index `k`.
    pub k: usize,
    /// `⌊o_i⌋`, `⌊o_j⌋`.
    pub floor: [isize; 2],
    /// The bilinear fractions `o - ⌊o⌋`.
    pub frac: [f32; 2],
    /// Use the half-step table (the first and last slice stand for half a
    /// slab: trapezoidal weights over the principal axis).
    pub half: bool,
}

/// The slices of `f` in front-to-back order.
pub fn slice_steps(f: &Factor) -> Vec<SliceStep> {
    let nk = f.n[2];
    let order: Box<dyn Iterator<Item = usize>> = if f.front_is_zero {
        Box::new(0..nk)
    } else {
        Box::new((0..nk).rev())
    };
    order
        .map(|k| {
            let o = f.slice_offset(k);
            let fl = o.map(f64::floor);
            SliceStep {
                k,
                floor: fl.map(|x| x as isize),
                frac: [(o[0] - fl[0]) as f32, (o[1] - fl[1]) as f32],
                half: k == 0 || k == nk - 1,
            }
        })
        .collect()
}

/// What the compositor reads.
pub struct Slices<'a, T> {
    /// The principal axis's encoding.
    pub rle: &'a AxisRle<T>,
    /// The transfer function's index mapping.
    pub lut: &'a Lut,
    /// Premultiplied, opacity-corrected entries for the slice step `δ`.
    pub full: &'a [[f32; 4]],
    /// The same for `δ / 2` (first and last slice).
    pub half: &'a [[f32; 4]],
    /// Pixels at or above this opacity are done (ERT; 1 or more: off).
    pub ert: f32,
    /// Visit only the non-transparent runs (false: every cell, for tests).
    pub empty_skip: bool,
}

#[inline(always)]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    (b - a) * t + a
}

/// The first open pixel at or after `u` (path compression on the way).
#[inline(always)]
fn find(next: &mut [u32], u: usize) -> usize {
    let mut r = u;
    while next[r] as usize != r {
        r = next[r] as usize;
    }
    let mut x = u;
    while next[x] as usize != r {
        let n = next[x] as usize;
        next[x] = r as u32;
        x = n;
    }
    r
}

/// Intermediate scanlines per band: a band (16 rows of f32 RGBA, a few
/// hundred KiB at most) stays in cache while every slice is composited
/// into it, and each slice's voxel scanlines for the band are read in
/// memory order.
pub const BAND: usize = 16;

/// Composites every slice of `steps` into the band of intermediate
/// scanlines from `v0` (`rows`: whole scanlines of width `w`, cleared to
/// zero), slice by slice, front to back; `next` is scratch.
pub fn band<T: Texel>(
    s: &Slices<'_, T>,
    steps: &[SliceStep],
    v0: usize,
    w: usize,
    rows: &mut [[f32; 4]],
    next: &mut Vec<u32>,
) -> SampleCounts {
    let nrows = rows.len() / w;
    next.clear();
    for _ in 0..nrows {
        next.extend(0..=w as u32);
    }
    let mut n = SampleCounts::default();
    for st in steps {
        for (b, row) in rows.chunks_exact_mut(w).enumerate() {
            let nx = &mut next[b * (w + 1)..(b + 1) * (w + 1)];
            scanline(s, st, v0 + b, row, nx, &mut n);
        }
    }
    n
}

/// Composites slice `st` into intermediate scanline `v` (`row`); `next`
/// holds its `w + 1` skip links.
#[inline]
fn scanline<T: Texel>(
    s: &Slices<'_, T>,
    st: &SliceStep,
    v: usize,
    row: &mut [[f32; 4]],
    next: &mut [u32],
    n: &mut SampleCounts,
) {
    let w = row.len();
    let [ni, nj, _] = s.rle.n;
    let cells = ni - 1;
    let all = [[0, cells as u32]];
    let j = v as isize + st.floor[1];
    if j < 0 || j as usize + 1 >= nj {
        return;
    }
    let j = j as usize;
    if find(next, 0) >= w {
        return;
    }
    let runs: &[[u32; 2]] = if s.empty_skip {
        s.rle.row_runs(st.k, j)
    } else {
        &all
    };
    let mut inrun = 0u64;
    let taken0 = n.taken;
    let table = if st.half { s.half } else { s.full };
    let (r0, r1) = (s.rle.row(st.k, j), s.rle.row(st.k, j + 1));
    let [fa, fb] = st.frac;
    let ia = st.floor[0];
    for run in runs {
        inrun += (run[1] - run[0]) as u64;
        // Pixels u with cell u + ia in the run, inside the image.
        let lo = ((run[0] as isize - ia).max(0) as usize).min(w);
        let hi = ((run[1] as isize - ia).max(0) as usize).min(w);
        let mut u = find(next, lo);
        while u < hi {
            // A stretch of open pixels: each column's lerp along j is
            // shared by the two pixels whose cells it bounds.
            let mut i = (u as isize + ia) as usize;
            let mut left = lerp(r0[i].f(), r1[i].f(), fb);
            loop {
                let right = lerp(r0[i + 1].f(), r1[i + 1].f(), fb);
                let c = table[s.lut.index(lerp(left, right, fa))];
                n.taken += 1;
                let p = &mut row[u];
                let t = 1.0 - p[3];
                *p = [
                    p[0] + t * c[0],
                    p[1] + t * c[1],
                    p[2] + t * c[2],
                    p[3] + t * c[3],
                ];
                if p[3] >= s.ert {
                    next[u] = u as u32 + 1;
                }
                u += 1;
                if u >= hi || next[u] as usize != u {
                    break;
                }
                left = right;
                i += 1;
            }
            if u < hi {
                u = find(next, u);
            }
        }
    }
    n.skipped_empty += cells as u64 - inrun;
    n.skipped_ert += inrun.saturating_sub(n.taken - taken0);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skip_links_find_the_next_open_pixel() {
        let mut next: Vec<u32> = (0..=6).collect();
        next[1] = 2;
        next[2] = 3;
        next[4] = 5;
        assert_eq!(find(&mut next, 0), 0);
        assert_eq!(find(&mut next, 1), 3);
        assert_eq!(next[1], 3, "compressed");
        assert_eq!(find(&mut next, 4), 5);
        assert_eq!(find(&mut next, 6), 6);
    }
}
