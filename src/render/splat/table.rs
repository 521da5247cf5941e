//! Footprint tables for orthographic views.
//!
//! In a parallel projection every voxel's footprint has the same conic `Q`
//! (the projected covariance does not depend on the voxel's position; see
//! [`super::footprint`]); only its centre, its centre optical depth
//! `tau_k l_k(x_k)` and its colour change. So the kernel
//! `g(d) = exp(-e(d))`, `e(d) = q0 dx² + 2 q1 dx dy + q2 dy²`, is tabulated
//! once per frame at `P x P` sub-pixel phases of the centre: the centre `x`
//! is rounded to the nearest `1/P` pixel, `x ≈ b + φ/P` (`b` integer,
//! `0 <= φ < P`), and the table holds `g` at the pixel centres
//! `(b + i + 1/2, ...)`, `i in [-k, k]`, i.e. at `d = i + 1/2 - φ/P`; weights
//! past the cut `e > k_cut²/2` are 0, and each row keeps the span of its
//! non-zero weights so that only those pixels are visited.
//!
//! Error: the centre moves by at most `1/(2P)` pixel (per axis), so a pixel's
//! weight changes by at most `|∇g| / (2P) * √2`; measured against the exact
//! path in `pvrsim bench --splat` (max-abs and RMSE in 1/255). Per pixel the
//! renderer is left with one lookup, one exponential
//! (`alpha = 1 - exp(-tau l0 g)`, which depends on the voxel) and the
//! premultiplied blend, instead of the conic and two exponentials.
//!
//! Perspective views keep the exact path (the conic changes per voxel).

use super::composite::Composite;
use super::footprint::Footprint;
use super::raster::floor_i;
use crate::render::cell::fastmath::exp_neg;

/// Pixels per run of alphas (two SSE vectors, one AVX vector).
pub const LANES: usize = 8;

/// The tabulated kernel of one orthographic frame.
#[derive(Debug, Clone)]
pub struct FootprintTable {
    /// Phases per pixel, `P`.
    phases: i64,
    /// Offsets `-k ..= k` around the rounded centre.
    k: i64,
    /// `2k + 1`.
    side: usize,
    /// Weights per table row: `side` rounded up to [`LANES`] (a multiple of
    /// 16 floats, 64 bytes, when `side > 8`), each row holding only its
    /// non-zero span from the row's start, zero-padded, so that runs of
    /// `LANES` weights from the span's start stay inside the row.
    stride: usize,
    /// Index in `weights` of the first row (64-byte aligned).
    first: usize,
    /// `g` at column `spans[..][0] + i` by `first + ((phase_y P + phase_x)
    /// side + row) stride + i`.
    weights: Vec<f32>,
    /// Non-zero columns `[first, end)` by `(phase_y P + phase_x) side + row`.
    spans: Vec<[u16; 2]>,
}

impl FootprintTable {
    /// The table of footprint shape `f` (its `q`, `rx`, `ry`; the centre is
    /// ignored), exponent cut `cut` (`k_cut²/2`), `phases` per pixel (>= 1).
    pub fn new(f: &Footprint, cut: f32, phases: u32) -> FootprintTable {
        let p = phases.max(1) as i64;
        let k = (f.rx.max(f.ry).ceil() as i64 + 1).max(1);
        let side = (2 * k + 1) as usize;
        let stride = side.next_multiple_of(LANES);
        let q = f.q.map(|x| x as f64);
        // One cache line more, to start the rows on a 64-byte boundary.
        let mut weights = vec![0.0f32; (p * p) as usize * side * stride + 16];
        let first = (64 - weights.as_ptr() as usize % 64) % 64 / 4;
        let mut spans = vec![[0u16; 2]; (p * p) as usize * side];
        for py in 0..p {
            for px in 0..p {
                let phase = (py * p + px) as usize;
                for row in 0..side {
                    let dy = (row as i64 - k) as f64 + 0.5 - py as f64 / p as f64;
                    let g = |col: usize| {
                        let dx = (col as i64 - k) as f64 + 0.5 - px as f64 / p as f64;
                        let e = q[0] * dx * dx + 2.0 * q[1] * dx * dy + q[2] * dy * dy;
                        (e <= cut as f64).then(|| (-e).exp() as f32)
                    };
                    // The cut is an ellipse: its columns in a row are one run.
                    let Some(c0) = (0..side).find(|&col| g(col).is_some()) else {
                        continue;
                    };
                    let c1 = (c0..side).find(|&col| g(col).is_none()).unwrap_or(side);
                    let row0 = first + (phase * side + row) * stride;
                    for col in c0..c1 {
                        weights[row0 + col - c0] = g(col).expect("inside the run");
                    }
                    spans[phase * side + row] = [c0 as u16, c1 as u16];
                }
            }
        }
        FootprintTable {
            phases: p,
            k,
            side,
            stride,
            first,
            weights,
            spans,
        }
    }

    /// Composites a splat centred at `(x, y)` with centre optical depth
    /// `depth0` and colour `rgb` into rows `[j0, j1)` held by `band`
    /// (`w` pixels per row), in front of what is there (premultiplied).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn draw<C: Composite>(
        &self,
        x: f32,
        y: f32,
        depth0: f32,
        rgb: [f32; 3],
        band: &mut [[f32; 4]],
        w: u32,
        j0: i64,
        j1: i64,
        comp: &mut C,
    ) {
        let (bx, by, phase) = self.split(x, y);
        // Rows by - k ..= by + k, clipped to the band.
        let ra = (by - self.k).max(j0);
        let rb = (by + self.k).min(j1 - 1);
        for j in ra..=rb {
            let row = (j - by + self.k) as usize;
            let [c0, c1] = self.spans[phase * self.side + row];
            // Columns: pixel i = bx - k + col, clipped to [0, w).
            let i_first = bx - self.k;
            let ca = (c0 as i64).max(-i_first);
            let cb = (c1 as i64).min(w as i64 - i_first);
            if ca >= cb {
                continue;
            }
            let wrow = &self.weights[self.first + (phase * self.side + row) * self.stride..]
                [..self.stride];
            let row_pix = &mut band[(j - j0) as usize * w as usize..][..w as usize];
            // alpha = 1 - exp(-tau l0 g): the alphas of LANES columns of the
            // run at a time (a fixed-width loop the compiler vectorises, no
            // scalar remainder: the row's zero padding fills the last run),
            // then the blend of those inside the image, [ca, cb).
            let (c0, ca, cb) = (c0 as usize, ca as usize, cb as usize);
            let mut cc = 0usize;
            while c0 + cc < cb {
                let lo = (c0 + cc).max(ca);
                let hi = (c0 + cc + LANES).min(cb);
                if lo < hi {
                    let wt: &[f32; LANES] = wrow[cc..cc + LANES].try_into().expect("padded row");
                    let mut a = [0.0f32; LANES];
                    for (a, &g) in a.iter_mut().zip(wt) {
                        *a = 1.0 - exp_neg(-depth0 * g);
                    }
                    let i0 = (i_first + lo as i64) as usize;
                    let i1 = (i_first + hi as i64) as usize;
                    comp.run(
                        &mut row_pix[i0..i1],
                        (j - j0) as usize,
                        i0,
                        &a[lo - c0 - cc..hi - c0 - cc],
                        rgb,
                    );
                }
                cc += LANES;
            }
        }
    }

    /// Asks the CPU to fetch the table rows of a splat centred at `(x, y)`
    /// into the cache (the phase blocks are hit at random, and the table
    /// is larger than the L2 cache at 32 phases): issued one splat ahead
    /// of drawing. A hint only; no effect on the image.
    #[inline(always)]
    pub fn prefetch(&self, x: f32, y: f32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let (_, _, phase) = self.split(x, y);
            let block = self.side * self.stride;
            let start = self.first + phase * block;
            let Some(rows) = self.weights.get(start..start + block) else {
                return;
            };
            for line in rows.chunks(16) {
                // SAFETY: a prefetch of memory inside `weights` (it never
                // faults and changes nothing observable).
                unsafe { _mm_prefetch::<_MM_HINT_T0>(line.as_ptr() as *const i8) };
            }
            if let Some(sp) = self.spans.get(phase * self.side..) {
                // SAFETY: as above, inside `spans`.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(sp.as_ptr() as *const i8) };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (x, y);
    }

    /// The centre `(x, y)` rounded to `1/P` pixel: the pixel `(bx, by)` and
    /// the phase index.
    #[inline(always)]
    fn split(&self, x: f32, y: f32) -> (i64, i64, usize) {
        let p = self.phases;
        let (xs, ys) = (floor_i(x * p as f32 + 0.5), floor_i(y * p as f32 + 0.5));
        // Euclidean quotient and remainder by P: by shift and mask when P
        // is a power of two (the default 32; an arithmetic shift is the
        // floor division), else by division.
        if p & (p - 1) == 0 {
            let sh = p.trailing_zeros();
            let m = p - 1;
            (xs >> sh, ys >> sh, (((ys & m) << sh) | (xs & m)) as usize)
        } else {
            (
                xs.div_euclid(p),
                ys.div_euclid(p),
                (ys.rem_euclid(p) * p + xs.rem_euclid(p)) as usize,
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::composite::Over;
    use super::*;

    /// Drawing one splat through the table equals the exact kernel at the
    /// rounded centre: `alpha = 1 - exp(-depth0 exp(-e))` per pixel, zero
    /// past the cut, and every pixel inside the cut is reached.
    #[test]
    fn table_draw_matches_the_exact_kernel_at_the_rounded_centre() {
        let f = Footprint {
            x: 0.0,
            y: 0.0,
            q: [0.21, -0.07, 0.33],
            l0: 1.0,
            rx: 3.0 * (0.33f32 / (4.0 * (0.21 * 0.33 - 0.07 * 0.07))).sqrt(),
            ry: 3.0 * (0.21f32 / (4.0 * (0.21 * 0.33 - 0.07 * 0.07))).sqrt(),
        };
        let cut = 4.5f32;
        // 8 phases: shift and mask; 12: division.
        for p in [8, 12] {
            let t = FootprintTable::new(&f, cut, p);
            let (w, h) = (24u32, 20u32);
            for (x, y) in [
                (10.3f32, 9.81f32),
                (11.0, 7.5),
                (3.06, 12.94),
                (0.4, 1.2),
                (-0.3, 0.2),
            ] {
                let mut img = vec![[0.0f32; 4]; (w * h) as usize];
                let depth0 = 0.7f32;
                t.draw(
                    x,
                    y,
                    depth0,
                    [1.0, 0.5, 0.25],
                    &mut img,
                    w,
                    0,
                    h as i64,
                    &mut Over,
                );
                let (xq, yq) = (
                    (x * p as f32 + 0.5).floor() / p as f32,
                    (y * p as f32 + 0.5).floor() / p as f32,
                );
                for j in 0..h {
                    for i in 0..w {
                        let (dx, dy) = ((i as f32 + 0.5 - xq) as f64, (j as f32 + 0.5 - yq) as f64);
                        let e = 0.21 * dx * dx + 2.0 * -0.07 * dx * dy + 0.33 * dy * dy;
                        let want = if e <= cut as f64 {
                            1.0 - (-(depth0 as f64) * (-e).exp()).exp()
                        } else {
                            0.0
                        };
                        let got = img[(j * w + i) as usize];
                        assert!(
                            (got[3] as f64 - want).abs() < 1e-5,
                            "({i},{j}) centre ({x},{y}): {} vs {want}",
                            got[3]
                        );
                        assert!((got[1] - 0.5 * got[3]).abs() < 1e-6);
                    }
                }
            }
        }
    }
}
