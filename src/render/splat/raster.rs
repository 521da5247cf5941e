//! Compositing one splat's footprint into a band of rows through a
//! [`Composite`] (back to front [`Over`](super::composite::Over), or front to
//! back [`Under`](super::composite::Under)),
//! `alpha(x) = 1 - exp(-tau_k l0 g(x))`,
//! `g(x) = exp(-e(d))`, `e(d) = q0 dx² + 2 q1 dx dy + q2 dy²`,
//! `d = x - x_k` (pixel centre minus splat centre), drawn where
//! `e <= k_cut²/2`.
//!
//! Two ways to get `g`:
//!
//! - [`draw_exact`]: the conic and `exp` at every pixel of the bounding box;
//! - [`draw_incremental`]: per row, the span where `e <= cut` in closed
//!   form (the roots of the quadratic in `dx`), then `g` by forward
//!   differences of the exponent, which is quadratic along the row:
//!   `g_{i+1} = g_i ρ_i`, `ρ_i = exp(-(e_{i+1} - e_i)) =
//!   exp(-(q0 (2 dx_i + 1) + 2 q1 dy))`, `ρ_{i+1} = ρ_i κ`, `κ = exp(-2 q0)`:
//!   two multiplications per pixel and three exponentials per row instead of
//!   the conic and an exponential per pixel. Inside the span `e in [0, cut]`,
//!   so `g in [exp(-cut), 1]` and every `ρ` is within `exp(±cut)`: no
//!   under- or overflow, and the f32 recurrence drifts by a few ulps over a
//!   row (tested against the exact kernel). Exact for any conic, so it
//!   serves perspective views too.
//!
//! Both compute `alpha` for a run of pixels first (a loop the compiler can
//! vectorise), then blend.

use super::buffer::{BandBuf, LANES};
use super::composite::Composite;
use crate::render::cell::fastmath::exp_neg;

/// What the per-pixel kernels read of one splat (a list record with its
/// shape filled in, [`super::record::Splat::full`]).
#[derive(Debug, Clone, Copy)]
pub struct SplatShape {
    /// Centre, continuous pixel coordinates.
    pub x: f32,
    /// Centre, vertical (downward).
    pub y: f32,
    /// Pre-halved conic `(q0, q1, q2)`.
    pub q: [f32; 3],
    /// Optical depth at the centre, `tau_k l_k(x_k)`.
    pub depth0: f32,
    /// Colour (not premultiplied).
    pub rgb: [f32; 3],
    /// Half-width of the bounding box, pixels.
    pub rx: f32,
    /// Half-height of the bounding box, pixels.
    pub ry: f32,
}

/// `floor(x)` as an integer without a libm call (the default x86-64 target
/// has no `roundss`, so `f32::floor` is a function call per use).
#[inline(always)]
pub fn floor_i(x: f32) -> i64 {
    let t = x as i64;
    t - ((t as f32) > x) as i64
}

/// `ceil(x)` as an integer without a libm call.
#[inline(always)]
pub fn ceil_i(x: f32) -> i64 {
    let t = x as i64;
    t + ((t as f32) < x) as i64
}

/// `e^x` for `|x|` up to ~80 by [`exp_neg`] (no libm call).
#[inline(always)]
fn exp_any(x: f32) -> f32 {
    if x <= 0.0 {
        exp_neg(x)
    } else {
        1.0 / exp_neg(-x)
    }
}

/// The pixels `p` whose centres `p + 1/2` lie within `r` of `c` (one
/// axis): `[ceil(c - r - 1/2), floor(c + r - 1/2)]`, empty when the first
/// exceeds the second.
#[inline(always)]
pub fn centres_within(c: f32, r: f32) -> (i64, i64) {
    (ceil_i(c - r - 0.5), floor_i(c + r - 0.5))
}

/// Rows of the bounding box inside `[j0, j1)`: pixel centres `j + 1/2`
/// within `ry` of the centre.
#[inline(always)]
pub fn rows(s: &SplatShape, j0: i64, j1: i64) -> (i64, i64) {
    let (ja, jb) = centres_within(s.y, s.ry);
    (ja.max(j0), jb.min(j1 - 1))
}

/// Composites `s` into `band`, whose first row is image row `j0`: the
/// conic and an exponential at every pixel of the bounding box.
#[inline]
pub fn draw_exact<C: Composite>(
    s: &SplatShape,
    band: &mut BandBuf,
    j0: i64,
    cut: f32,
    comp: &mut C,
) {
    let w = band.width();
    let (ja, jb) = rows(s, j0, j0 + band.rows() as i64);
    if ja > jb {
        return;
    }
    let (ia, ib) = centres_within(s.x, s.rx);
    let (ia, ib) = (ia.max(0), ib.min(w as i64 - 1));
    for j in ja..=jb {
        let dy = j as f32 + 0.5 - s.y;
        for i in ia..=ib {
            let dx = i as f32 + 0.5 - s.x;
            let e = s.q[0] * dx * dx + 2.0 * s.q[1] * dx * dy + s.q[2] * dy * dy;
            if e > cut {
                continue;
            }
            let alpha = 1.0 - exp_neg(-s.depth0 * exp_neg(-e));
            let r = (j - j0) as usize;
            let mut a8 = [0.0f32; LANES];
            a8[0] = alpha;
            comp.run(band, r, i as usize, &a8, 1, s.rgb);
        }
    }
}

/// Composites `s` into rows `[j0, j1)` held by `band` (`w` pixels a row) by
/// per-row spans and forward differences (module doc).
#[inline]
pub fn draw_incremental<C: Composite>(
    s: &SplatShape,
    band: &mut BandBuf,
    j0: i64,
    cut: f32,
    comp: &mut C,
) {
    let w = band.width();
    let (ja, jb) = rows(s, j0, j0 + band.rows() as i64);
    if ja > jb {
        return;
    }
    let [q0, q1, q2] = s.q;
    let kappa = exp_neg(-2.0 * q0);
    let inv_q0 = 1.0 / q0;
    let mut alpha = [0.0f32; 64];
    for j in ja..=jb {
        let dy = j as f32 + 0.5 - s.y;
        // e(dx) = q0 dx² + 2 (q1 dy) dx + q2 dy² <= cut between the roots.
        let b = q1 * dy;
        let disc = b * b - q0 * (q2 * dy * dy - cut);
        if disc < 0.0 {
            continue;
        }
        let root = disc.sqrt();
        let (lo, hi) = ((-b - root) * inv_q0, (-b + root) * inv_q0);
        // Pixels i with dx = i + 1/2 - x in [lo, hi].
        let ia = ceil_i(s.x - 0.5 + lo).max(0);
        let ib = floor_i(s.x - 0.5 + hi).min(w as i64 - 1);
        if ia > ib {
            continue;
        }
        let dx0 = ia as f32 + 0.5 - s.x;
        let e0 = (q0 * dx0 + 2.0 * b) * dx0 + q2 * dy * dy;
        let mut g = exp_neg(-e0.max(0.0));
        let mut rho = exp_any((-(q0 * (2.0 * dx0 + 1.0) + 2.0 * b)).clamp(-cut, cut));
        let mut i = ia as usize;
        let end = ib as usize + 1;
        while i < end {
            let n = (end - i).min(alpha.len());
            for a in &mut alpha[..n] {
                *a = g;
                g *= rho;
                rho *= kappa;
            }
            for a in &mut alpha[..n] {
                *a = 1.0 - exp_neg(-s.depth0 * *a);
            }
            comp.run(band, (j - j0) as usize, i, &alpha, n, s.rgb);
            i += n;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::composite::Over;
    use super::*;

    /// The incremental kernel draws the exact kernel's alphas (to 2e-5)
    /// on the exact kernel's pixels, for round, elongated and tilted
    /// conics, centres at any sub-pixel position and clipped at the edges.
    #[test]
    fn incremental_matches_exact() {
        let (w, h) = (40u32, 30u32);
        let cut = 4.5f32;
        for q in [
            [0.3f32, 0.0, 0.3],
            [0.21, -0.07, 0.33],
            [0.05, 0.04, 0.6],
            [1.2, 0.5, 0.4],
        ] {
            let det = q[0] * q[2] - q[1] * q[1];
            // Bounding half-sizes from the conic: k sqrt(V_00), V = (2Q)^-1.
            let (rx, ry) = (
                (2.0 * cut * q[2] / (2.0 * det)).sqrt(),
                (2.0 * cut * q[0] / (2.0 * det)).sqrt(),
            );
            for (x, y) in [(20.3f32, 14.81f32), (0.7, 1.1), (39.2, 29.6), (11.5, 7.5)] {
                let s = SplatShape {
                    x,
                    y,
                    q,
                    depth0: 0.8,
                    rgb: [1.0, 0.5, 0.25],
                    rx,
                    ry,
                };
                let (w, h) = (w as usize, h as usize);
                let mut a = BandBuf::new(w, h);
                draw_exact(&s, &mut a, 0, cut, &mut Over);
                // Two bands, to check the row clipping.
                let mut top = BandBuf::new(w, 13);
                let mut bottom = BandBuf::new(w, h - 13);
                draw_incremental(&s, &mut top, 0, cut, &mut Over);
                draw_incremental(&s, &mut bottom, 13, cut, &mut Over);
                let mut b = vec![[0.0f32; 4]; w * h];
                top.write_rgba(&mut b[..w * 13]);
                bottom.write_rgba(&mut b[w * 13..]);
                let mut av = vec![[0.0f32; 4]; w * h];
                a.write_rgba(&mut av);
                let mut drawn = 0;
                for (k, (p, r)) in av.iter().zip(&b).enumerate() {
                    drawn += (p[3] > 0.0) as u32;
                    // A pixel at e = cut may fall either side of the cut.
                    let edge = p[3].min(r[3]) == 0.0 && p[3].max(r[3]) < 0.01;
                    for (c, (pc, rc)) in p.iter().zip(r).enumerate() {
                        assert!(
                            (pc - rc).abs() < 2e-5 || edge,
                            "q {q:?} centre ({x},{y}) pixel {k} channel {c}: exact {pc} incremental {rc}"
                        );
                    }
                }
                assert!(drawn > 3, "q {q:?} ({x},{y}): {drawn} pixels");
            }
        }
    }
}
