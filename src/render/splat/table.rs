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
//! (`alpha = 1 - exp(-tau l0 g)`, which depends on the voxel; by
//! [`one_minus_exp2`]) and the premultiplied blend, instead of the conic and
//! two exponentials.
//!
//! Perspective views keep the exact path (the conic changes per voxel).

use super::buffer::{BandBuf, LANES};
use super::composite::Composite;
use super::footprint::Footprint;
use super::raster::floor_i;

/// One table row of one phase: its non-zero columns `[c0, c1)` and where
/// their weights start in the phase's packed block.
#[derive(Debug, Clone, Copy, Default)]
struct RowSpan {
    c0: u32,
    c1: u32,
    off: u32,
}

/// One phase's packed block: rows `[row0, row1)` are the non-empty ones,
/// their weights packed row after row from `start` (`len` of them, the
/// block padded with zeros to a multiple of [`LANES`]).
#[derive(Debug, Clone, Copy, Default)]
struct PhaseBlock {
    start: u32,
    len: u32,
    row0: u32,
    row1: u32,
}

/// The tabulated kernel of one orthographic frame.
///
/// Layout: per phase, the non-zero weights of all rows packed into one
/// block (row after row, no per-row padding), so that the alphas of a whole
/// footprint are computed in runs of [`LANES`] with no idle lanes but the
/// last run's; then each row blends its slice of them.
#[derive(Debug, Clone)]
pub struct FootprintTable {
    /// Phases per pixel, `P`.
    phases: i64,
    /// Offsets `-k ..= k` around the rounded centre.
    k: i64,
    /// `2k + 1`.
    side: usize,
    /// Packed weights of every phase, block after block (each starting at
    /// a multiple of [`LANES`] floats and zero-padded to one).
    weights: Vec<f32>,
    /// Blocks by phase index `phase_y P + phase_x`.
    blocks: Vec<PhaseBlock>,
    /// Row spans by `phase side + row`.
    spans: Vec<RowSpan>,
    /// Largest padded block: the alpha scratch a band needs.
    max_len: usize,
}

impl FootprintTable {
    /// The table of footprint shape `f` (its `q`, `rx`, `ry`; the centre is
    /// ignored), exponent cut `cut` (`k_cut²/2`), `phases` per pixel (>= 1).
    pub fn new(f: &Footprint, cut: f32, phases: u32) -> FootprintTable {
        let p = phases.max(1) as i64;
        let k = (f.rx.max(f.ry).ceil() as i64 + 1).max(1);
        let side = (2 * k + 1) as usize;
        let q = f.q.map(|x| x as f64);
        let mut weights = Vec::new();
        let mut blocks = vec![PhaseBlock::default(); (p * p) as usize];
        let mut spans = vec![RowSpan::default(); (p * p) as usize * side];
        let mut max_len = 0;
        for py in 0..p {
            for px in 0..p {
                let phase = (py * p + px) as usize;
                let start = weights.len();
                let (mut row0, mut row1) = (side, 0);
                for row in 0..side {
                    let dy = (row as i64 - k) as f64 + 0.5 - py as f64 / p as f64;
                    let g = |col: usize| {
                        let dx = (col as i64 - k) as f64 + 0.5 - px as f64 / p as f64;
                        let e = q[0] * dx * dx + 2.0 * q[1] * dx * dy + q[2] * dy * dy;
                        (e <= cut as f64).then(|| (-e).exp() as f32)
                    };
                    // The cut is an ellipse: its columns in a row are one
                    // run, and its rows one run of rows.
                    let off = (weights.len() - start) as u32;
                    let Some(c0) = (0..side).find(|&col| g(col).is_some()) else {
                        spans[phase * side + row] = RowSpan { c0: 0, c1: 0, off };
                        continue;
                    };
                    let c1 = (c0..side).find(|&col| g(col).is_none()).unwrap_or(side);
                    weights.extend((c0..c1).map(|col| g(col).expect("inside the run")));
                    spans[phase * side + row] = RowSpan {
                        c0: c0 as u32,
                        c1: c1 as u32,
                        off,
                    };
                    row0 = row0.min(row);
                    row1 = row + 1;
                }
                let len = (weights.len() - start).next_multiple_of(LANES);
                weights.resize(start + len, 0.0);
                max_len = max_len.max(len);
                blocks[phase] = PhaseBlock {
                    start: start as u32,
                    len: len as u32,
                    row0: row0.min(row1) as u32,
                    row1: row1 as u32,
                };
            }
        }
        assert!(
            weights.len() < u32::MAX as usize,
            "footprint table of {} weights",
            weights.len()
        );
        FootprintTable {
            phases: p,
            k,
            side,
            weights,
            blocks,
            spans,
            max_len,
        }
    }

    /// Alpha scratch for [`FootprintTable::draw`]: one per band.
    pub fn scratch(&self) -> Vec<f32> {
        // A run starts anywhere in the block and reads whole vectors.
        vec![0.0; self.max_len + LANES]
    }

    /// Composites a splat centred at `(x, y)` with centre optical depth
    /// `depth0` and colour `rgb` into `band`, whose first row is image row
    /// `j0` (premultiplied, through `comp`). `alpha` is scratch from
    /// [`FootprintTable::scratch`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn draw<C: Composite>(
        &self,
        x: f32,
        y: f32,
        depth0: f32,
        rgb: [f32; 3],
        band: &mut BandBuf,
        j0: i64,
        alpha: &mut [f32],
        comp: &mut C,
    ) {
        let (bx, by, phase) = self.split(x, y);
        let (w, j1) = (band.width(), j0 + band.rows() as i64);
        let b = self.blocks[phase];
        // Table rows [row0, row1) are pixel rows by - k + row; clipped to
        // the band.
        let top = by - self.k;
        let ra = (b.row0 as i64).max(j0 - top);
        let rb = (b.row1 as i64).min(j1 - top);
        if ra >= rb {
            return;
        }
        let spans = &self.spans[phase * self.side..][..self.side];
        let (ra, rb) = (ra as usize, rb as usize);
        // alpha = 1 - exp(-tau l0 g) for the packed weights of rows
        // [ra, rb), LANES at a time from a run boundary (a fixed-width loop
        // the compiler vectorises; the block's zero padding fills the last
        // run).
        let lo = spans[ra].off as usize / LANES * LANES;
        let hi = (spans[rb - 1].off as usize + (spans[rb - 1].c1 - spans[rb - 1].c0) as usize)
            .next_multiple_of(LANES);
        let wts = &self.weights[b.start as usize..][..b.len as usize];
        // exp(-depth0 g) = 2^(-depth0 log2(e) g).
        let d2 = depth0 * std::f32::consts::LOG2_E;
        for (a8, g8) in alpha[lo..hi]
            .chunks_exact_mut(LANES)
            .zip(wts[lo..hi].chunks_exact(LANES))
        {
            // Through fixed-size arrays, so that the loop is one vector.
            let g8: &[f32; LANES] = g8.try_into().expect("LANES");
            let mut a = [0.0f32; LANES];
            for (a, &g) in a.iter_mut().zip(g8) {
                *a = one_minus_exp2(-d2 * g);
            }
            a8.copy_from_slice(&a);
        }
        // Columns: pixel i = bx - k + col, clipped to [0, w).
        let i_first = bx - self.k;
        let (cmin, cmax) = (-i_first, w as i64 - i_first);
        for (row, s) in spans.iter().enumerate().take(rb).skip(ra) {
            let ca = (s.c0 as i64).max(cmin);
            let cb = (s.c1 as i64).min(cmax);
            if ca >= cb {
                continue;
            }
            let r = (top + row as i64 - j0) as usize;
            let i0 = (i_first + ca) as usize;
            let i1 = (i_first + cb) as usize;
            let a0 = s.off as usize + (ca - s.c0 as i64) as usize;
            comp.run(band, r, i0, &alpha[a0..], i1 - i0, rgb);
        }
    }

    /// Asks the CPU to fetch the table rows of a splat centred at `(x, y)`
    /// into the cache (the phase blocks are hit at random, and at 32 phases
    /// the table, ~330 KB at 512^2 of 256^3, shares the L2 cache with the
    /// band): issued one splat ahead
    /// of drawing. A hint only; no effect on the image.
    #[inline(always)]
    pub fn prefetch(&self, x: f32, y: f32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let (_, _, phase) = self.split(x, y);
            let b = self.blocks[phase];
            let Some(block) = self
                .weights
                .get(b.start as usize..(b.start + b.len) as usize)
            else {
                return;
            };
            for line in block.chunks(16) {
                // SAFETY: a prefetch of memory inside `weights` (it never
                // faults and changes nothing observable).
                unsafe { _mm_prefetch::<_MM_HINT_T0>(line.as_ptr() as *const i8) };
            }
            if let Some(sp) = self.spans.get(phase * self.side..(phase + 1) * self.side) {
                for line in sp.chunks(5) {
                    // SAFETY: as above, inside `spans`.
                    unsafe { _mm_prefetch::<_MM_HINT_T0>(line.as_ptr() as *const i8) };
                }
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

/// `1 - 2^x` for `x <= 0` (inputs below -126 give 1), the table path's
/// per-pixel alpha `1 - exp(-tau l0 g)` with `x = -tau l0 log2(e) g`.
///
/// `x = k + f`, `k` the nearest integer (by the 1.5 * 2^23 trick, no
/// libm call), `|f| <= 1/2`; `2^f = e^(f ln 2)` by its Taylor polynomial
/// to degree 5 (relative error below `(ln 2 / 2)^6 / 720 < 2.5e-6`, i.e.
/// under 1e-3/255 on an alpha), `2^k` put into the exponent bits. Fewer
/// operations than `exp_neg` (no two-part `ln 2` reduction, degree 5
/// instead of 7), on a vector of lanes at a time.
#[inline(always)]
pub fn one_minus_exp2(x: f32) -> f32 {
    let x = x.max(-126.0);
    const MAGIC: f32 = 12_582_912.0;
    let k = (x + MAGIC) - MAGIC;
    let f = (x - k) * std::f32::consts::LN_2;
    let p = 1.0 + f * (1.0 + f * (0.5 + f * (1.0 / 6.0 + f * (1.0 / 24.0 + f * (1.0 / 120.0)))));
    // 2^k: the biased exponent k + 127 (in [1, 127]) read off the mantissa
    // bits of (k + 127 + 2^23).
    let biased = (k + (127.0 + 8_388_608.0)).to_bits() & 0x007f_ffff;
    1.0 - p * f32::from_bits(biased << 23)
}

#[cfg(test)]
mod tests {
    use super::super::composite::Over;
    use super::*;

    /// `one_minus_exp2` is `1 - 2^x` to 3e-6 (absolute) over `[-130, 0]`,
    /// exactly 0 at 0, and monotone on a fine grid (to its error).
    #[test]
    fn one_minus_exp2_is_accurate() {
        assert_eq!(one_minus_exp2(0.0), 0.0);
        let mut last = 0.0f32;
        for i in 0..=1_300_000 {
            let x = -(i as f32) * 1e-4;
            let got = one_minus_exp2(x) as f64;
            let want = 1.0 - (x as f64).exp2();
            assert!((got - want).abs() < 3e-6, "x {x}: {got} vs {want}");
            assert!(got as f32 >= last - 5e-6, "not monotone at {x}");
            last = got as f32;
        }
    }

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
                let mut band = BandBuf::new(w as usize, h as usize);
                let mut scratch = t.scratch();
                let depth0 = 0.7f32;
                t.draw(
                    x,
                    y,
                    depth0,
                    [1.0, 0.5, 0.25],
                    &mut band,
                    0,
                    &mut scratch,
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
                        let got = band.pixel(j as usize, i as usize);
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
