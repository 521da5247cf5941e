//! Integrating one ray segment through one tetrahedron.
//!
//! Inside a tetrahedron the scalar is linear along the ray, so a segment is
//! described by its scalar at entry `s_a`, at exit `s_b`, and its length
//! `l` (world units). With `k = l / unit_distance` and `x in [0, 1]` the
//! position along the segment:
//!
//! - `o(x)`, `c(x)`: the transfer function at `s(x)`, linear in `x` between the
//!   control points the segment crosses;
//! - optical depth `D(x) = k * ∫_0^x -ln(1 - o(x')) dx'`, alpha `A(x) = 1 - e^{-D(x)}`;
//! - colour `C = ∫_0^1 c(x) dA(x)`.
//!
//! **Exact integrator.** The segment is split at the control points; on each
//! piece `u = 1 - o` is linear, so the optical depth has a closed form
//! (`∫ -ln u dx = (u_1 λ_1 - u_0 λ_0) / (u_1 - u_0) + 1` with `λ = -ln u`, and
//! a series when `u_1 ≈ u_0`). Integrating the colour by parts, with `c` linear
//! on the piece, leaves a single smooth scalar integral:
//!
//! `C = c_1 A(1) - (c_1 - c_0) ∫_0^1 A(x) dx`,
//!
//! which Simpson's rule evaluates from `A(1/2)` and `A(1)`. Pieces whose optical
//! depth or opacity change is large are cut into equal sub-steps first, which
//! keeps the error under 1e-4 (tested against an f64 adaptive quadrature).
//!
//! **Midpoint integrator.** One transfer-function lookup at the segment's
//! middle: `A = 1 - (1 - o_m)^k`, `C = c_m A`. The classic projected-tetrahedra
//! approximation; its image error against the reference is reported, not hidden.

use super::fastmath::{exp_neg, fclamp, fmax, fmin, ln};
use crate::base::segment::Rgba;
use crate::scene::transfer::{TransferFunction, OPACITY_MAX};

mod batch;
#[cfg(test)]
mod tests;

pub use batch::{Batch, BATCH, NO_PIECE};

/// Which integrator turns a segment's `(s_a, s_b, length)` into colour and alpha.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Integrator {
    /// Piecewise closed-form optical depth + Simpson on the colour; within 1e-4.
    Exact,
    /// Scalar at the middle, one transfer-function lookup.
    Midpoint,
}

impl std::fmt::Display for Integrator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Integrator::Exact => "exact",
            Integrator::Midpoint => "midpoint",
        })
    }
}

/// [`PreparedTf::optical_depth_bound`]'s factor: the largest extinction
/// of the pieces' opacities (as the integrators clamp them), per world
/// unit, rounded up by a relative 1e-6.
fn depth_per_length(pieces: &[Piece], unit_distance: f64) -> f32 {
    let o_max = pieces
        .iter()
        .flat_map(|p| [p.o0, p.o1])
        .fold(0.0f64, |m, o| m.max(f64::from(o)));
    let lambda = -(1.0 - o_max.min(OPACITY_MAX)).ln() / unit_distance;
    if lambda.is_finite() {
        (lambda * (1.0 + 1e-6)) as f32
    } else {
        f32::INFINITY
    }
}

/// One linear stretch of the transfer function, `[s0, s1]`, in f32.
#[derive(Debug, Clone, Copy)]
struct Piece {
    s0: f32,
    /// `1 / (s1 - s0)`, 0 for the constant pieces outside the control points.
    inv_w: f32,
    o0: f32,
    o1: f32,
    c0: [f32; 3],
    c1: [f32; 3],
}

/// The pieces again, structure of arrays, for the vectorised batch math
/// (which gathers a lane's parameters by piece index).
#[derive(Debug, Clone)]
struct PieceTable {
    s0: Vec<f32>,
    inv_w: Vec<f32>,
    o0: Vec<f32>,
    /// `o1 - o0`.
    d_o: Vec<f32>,
    c0: [Vec<f32>; 3],
    /// `c1 - c0`.
    d_c: [Vec<f32>; 3],
}

impl PieceTable {
    fn new(pieces: &[Piece]) -> PieceTable {
        let col = |f: &dyn Fn(&Piece) -> f32| pieces.iter().map(f).collect::<Vec<f32>>();
        PieceTable {
            s0: col(&|p| p.s0),
            inv_w: col(&|p| p.inv_w),
            o0: col(&|p| p.o0),
            d_o: col(&|p| p.o1 - p.o0),
            c0: [0, 1, 2].map(|c| col(&|p| p.c0[c])),
            d_c: [0, 1, 2].map(|c| col(&|p| p.c1[c] - p.c0[c])),
        }
    }
}

/// The transfer function prepared for fast evaluation in f32.
#[derive(Debug, Clone)]
pub struct PreparedTf {
    /// Control-point scalars, ascending (the kinks).
    breaks: Vec<f32>,
    /// `breaks` followed by `+inf`, so `breaks_inf[i]` exists for every piece `i`.
    breaks_inf: Vec<f32>,
    /// Piece lookup table over `[lut_lo, lut_lo + LUT / lut_scale)`: the piece
    /// at the start of each cell; one or two comparisons finish the job.
    lut: Vec<u16>,
    lut_lo: f32,
    lut_scale: f32,
    /// `breaks.len() + 1` pieces: below the first point, between each pair, above the last.
    pieces: Vec<Piece>,
    /// `pieces` as structure of arrays.
    table: PieceTable,
    /// The maximal closed scalar intervals on which the opacity is zero
    /// (as `eval` computes it), ascending: a cell is transparent iff its
    /// scalar range lies inside one.
    zero_runs: Vec<(f32, f32)>,
    inv_unit_distance: f32,
    /// Optical depth a world unit can hold at most: `-ln(1 - o_max) /
    /// unit_distance` over the opacities of the pieces, rounded up
    /// (infinite if an opacity reaches 1).
    depth_per_length: f32,
}

impl PreparedTf {
    /// Prepares `tf` for the integrators.
    pub fn new(tf: &TransferFunction) -> PreparedTf {
        let p = &tf.points;
        let f = |v: f64| v as f32;
        let c = |i: usize| p[i].rgb.map(f);
        let mut pieces = Vec::with_capacity(p.len() + 1);
        pieces.push(Piece {
            s0: f(p[0].s),
            inv_w: 0.0,
            o0: f(p[0].opacity),
            o1: f(p[0].opacity),
            c0: c(0),
            c1: c(0),
        });
        for i in 0..p.len() - 1 {
            let w = p[i + 1].s - p[i].s;
            pieces.push(Piece {
                s0: f(p[i].s),
                inv_w: if w > 0.0 { (1.0 / w) as f32 } else { 0.0 },
                o0: f(p[i].opacity),
                o1: f(p[i + 1].opacity),
                c0: c(i),
                c1: c(i + 1),
            });
        }
        let l = p.len() - 1;
        pieces.push(Piece {
            s0: f(p[l].s),
            inv_w: 0.0,
            o0: f(p[l].opacity),
            o1: f(p[l].opacity),
            c0: c(l),
            c1: c(l),
        });
        let breaks: Vec<f32> = p.iter().map(|c| f(c.s)).collect();
        let runs = zero_runs(&pieces, &breaks);
        let mut breaks_inf = breaks.clone();
        breaks_inf.push(f32::INFINITY);
        let (lo, hi) = (breaks[0], breaks[breaks.len() - 1]);
        let lut_scale = if hi > lo { LUT as f32 / (hi - lo) } else { 0.0 };
        let count = |s: f32| breaks.iter().take_while(|&&b| b <= s).count();
        let lut = (0..LUT)
            .map(|k| {
                if lut_scale > 0.0 {
                    count(lo + k as f32 / lut_scale).min(breaks.len()) as u16
                } else {
                    0
                }
            })
            .collect();
        PreparedTf {
            breaks,
            breaks_inf,
            lut,
            lut_lo: lo,
            lut_scale,
            table: PieceTable::new(&pieces),
            zero_runs: runs,
            depth_per_length: depth_per_length(&pieces, tf.unit_distance),
            pieces,
            inv_unit_distance: (1.0 / tf.unit_distance) as f32,
        }
    }

    /// An upper bound on the optical depth `D` of any segment `length` world
    /// units long, whatever its scalars: each integrator's `1 - alpha` is
    /// `e^{-D}` (a product of such factors where the exact one cuts a
    /// segment), computed to a relative error far below 1e-3.
    #[inline(always)]
    pub fn optical_depth_bound(&self, length: f32) -> f32 {
        length * self.depth_per_length
    }

    /// The largest optical depth a world unit can hold, whatever the
    /// scalars ([`PreparedTf::optical_depth_bound`] of a unit length).
    pub fn max_depth_per_length(&self) -> f32 {
        self.depth_per_length
    }

    /// Index of the piece holding `s` (`s` in `[breaks[i-1], breaks[i])`).
    #[inline(always)]
    fn piece_index(&self, s: f32) -> usize {
        if s < self.lut_lo {
            return 0;
        }
        // round(t - 1) by the 2^23 trick (a float-to-usize cast is slow
        // without SSE4.1): at most floor(t), so the table entry is a lower bound.
        let t = fclamp((s - self.lut_lo) * self.lut_scale, 1.0, LUT as f32);
        let k = ((t - 1.0 + 8_388_608.0).to_bits() & 0x007f_ffff) as usize;
        let mut i = self.lut[k] as usize;
        // The table gives the piece at the cell's start (a lower bound, never
        // above the answer); step over the breaks inside the cell.
        while self.breaks_inf[i] <= s {
            i += 1;
        }
        i
    }

    /// Opacity and colour at `s`.
    #[inline(always)]
    fn eval(&self, s: f32) -> (f32, [f32; 3]) {
        let p = &self.pieces[self.piece_index(s)];
        let w = ((s - p.s0) * p.inv_w).clamp(0.0, 1.0);
        let lerp = |a: f32, b: f32| a + (b - a) * w;
        (
            lerp(p.o0, p.o1),
            [
                lerp(p.c0[0], p.c1[0]),
                lerp(p.c0[1], p.c1[1]),
                lerp(p.c0[2], p.c1[2]),
            ],
        )
    }

    /// How many pieces (so a piece index is below it).
    pub fn piece_count(&self) -> usize {
        self.pieces.len()
    }

    /// The piece holding the whole scalar interval `[lo, hi]`, if one does
    /// (then no segment with scalars in it crosses a control point).
    pub fn single_piece(&self, lo: f32, hi: f32) -> u16 {
        let i = self.piece_index(lo);
        if i == self.piece_index(hi) {
            i as u16
        } else {
            NO_PIECE
        }
    }

    /// Whether the opacity is zero everywhere on `[lo, hi]` (cells whose
    /// scalar interval maps to zero opacity are skipped before projection).
    pub fn is_transparent(&self, lo: f32, hi: f32) -> bool {
        self.zero_runs.iter().any(|&(a, b)| a <= lo && hi <= b)
    }

    /// Colour and alpha of a segment through a tet, `s_a` at the front, `s_b`
    /// at the back, `length` world units long.
    #[inline(always)]
    pub fn integrate(&self, integrator: Integrator, s_a: f32, s_b: f32, length: f32) -> Rgba {
        match integrator {
            Integrator::Exact => self.exact(s_a, s_b, length),
            Integrator::Midpoint => self.midpoint(s_a, s_b, length),
        }
    }

    /// The midpoint rule: one lookup at `(s_a + s_b) / 2`.
    #[inline(always)]
    pub fn midpoint(&self, s_a: f32, s_b: f32, length: f32) -> Rgba {
        let (o, c) = self.eval(0.5 * (s_a + s_b));
        let k = length * self.inv_unit_distance;
        let a = 1.0 - exp_neg(k * ln(1.0 - o.min(OPACITY_MAX as f32)));
        Rgba {
            rgb: [c[0] * a, c[1] * a, c[2] * a],
            a,
        }
    }

    /// The exact integrator (see the module doc).
    #[inline]
    pub fn exact(&self, s_a: f32, s_b: f32, length: f32) -> Rgba {
        let k = length * self.inv_unit_distance;
        let (i_a, i_b) = (self.piece_index(s_a), self.piece_index(s_b));
        if i_a == i_b {
            return self.piece(i_a, s_a, s_b, k);
        }
        // Split at the control points crossed, in the direction of travel.
        let inv_ds = 1.0 / (s_b - s_a);
        let mut acc = Rgba::CLEAR;
        let (mut s_prev, mut x_prev) = (s_a, 0.0f32);
        let mut cut = |acc: &mut Rgba, i: usize, s_next: f32, x_next: f32| {
            *acc = acc.over(self.piece(i, s_prev, s_next, k * (x_next - x_prev)));
            s_prev = s_next;
            x_prev = x_next;
        };
        if i_b > i_a {
            for i in i_a..i_b {
                let s = self.breaks[i];
                cut(&mut acc, i, s, (s - s_a) * inv_ds);
            }
            cut(&mut acc, i_b, s_b, 1.0);
        } else {
            for i in (i_b + 1..=i_a).rev() {
                let s = self.breaks[i - 1];
                cut(&mut acc, i, s, (s - s_a) * inv_ds);
            }
            cut(&mut acc, i_b, s_b, 1.0);
        }
        acc
    }

    /// One piece: `s` from `s0` to `s1`, both inside piece `i`, `k` unit distances long.
    #[inline(always)]
    fn piece(&self, i: usize, s0: f32, s1: f32, k: f32) -> Rgba {
        let p = &self.pieces[i];
        let at = |s: f32| {
            let w = ((s - p.s0) * p.inv_w).clamp(0.0, 1.0);
            let o = (p.o0 + (p.o1 - p.o0) * w).min(OPACITY_MAX as f32);
            (
                1.0 - o,
                [
                    p.c0[0] + (p.c1[0] - p.c0[0]) * w,
                    p.c0[1] + (p.c1[1] - p.c0[1]) * w,
                    p.c0[2] + (p.c1[2] - p.c0[2]) * w,
                ],
            )
        };
        let (u0, c0) = at(s0);
        let (u1, c1) = at(s1);
        if u0 >= 1.0 && u1 >= 1.0 {
            return Rgba::CLEAR; // transparent piece
        }
        let (l0, l1) = (-ln(u0), -ln(u1));
        // Sub-steps: keep each one's optical depth and relative change of
        // transmittance-per-unit small enough for Simpson's rule (see tests).
        let d_est = k * l0.max(l1);
        let rel = (u1 - u0).abs() / u0.min(u1);
        let n = (d_est * 2.5).max(rel * 3.0).ceil().clamp(1.0, 64.0) as usize;
        if n == 1 {
            return sub_step(u0, u1, l0, l1, c0, c1, k);
        }
        let inv_n = 1.0 / n as f32;
        let mut acc = Rgba::CLEAR;
        let (mut ua, mut la, mut ca) = (u0, l0, c0);
        for j in 1..=n {
            let x = j as f32 * inv_n;
            let ub = u0 + (u1 - u0) * x;
            let cb = [
                c0[0] + (c1[0] - c0[0]) * x,
                c0[1] + (c1[1] - c0[1]) * x,
                c0[2] + (c1[2] - c0[2]) * x,
            ];
            let lb = if j == n { l1 } else { -ln(ub) };
            acc = acc.over(sub_step(ua, ub, la, lb, ca, cb, k * inv_n));
            (ua, la, ca) = (ub, lb, cb);
        }
        acc
    }
}

/// The maximal closed intervals on which the piecewise linear opacity is
/// zero: unions of pieces whose both ends are zero (the outer pieces reach
/// to infinity) and of control points of zero opacity. Inside a piece with
/// a nonzero end the opacity is nonzero everywhere but at that other end.
fn zero_runs(pieces: &[Piece], breaks: &[f32]) -> Vec<(f32, f32)> {
    let last = pieces.len() - 1;
    let mut runs: Vec<(f32, f32)> = Vec::new();
    for (k, p) in pieces.iter().enumerate() {
        let start = if k == 0 {
            f32::NEG_INFINITY
        } else {
            breaks[k - 1]
        };
        let end = if k == last { f32::INFINITY } else { breaks[k] };
        if p.o0 <= 0.0 && p.o1 <= 0.0 {
            runs.push((start, end));
        } else if p.o0 <= 0.0 {
            runs.push((start, start));
        } else if p.o1 <= 0.0 {
            runs.push((end, end));
        }
    }
    runs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut merged: Vec<(f32, f32)> = Vec::new();
    for r in runs {
        match merged.last_mut() {
            Some(m) if r.0 <= m.1 => m.1 = m.1.max(r.1),
            _ => merged.push(r),
        }
    }
    merged
}

/// Cells of the piece lookup table.
const LUT: usize = 1024;

/// `∫_0^1 -ln(u(x)) dx` for `u` linear from `u0` to `u1`, given `λ = -ln u` at
/// both ends. Exact form `(u1 λ1 - u0 λ0) / (u1 - u0) + 1`; when the ends are
/// close, the series `(λ0 + λ1)/2 - Σ_{n≥1} e^{2n} / (2n + 1)` with
/// `e = (u1 - u0) / (u1 + u0)` (from `artanh(e)/e`), which avoids the cancellation.
#[inline(always)]
pub(super) fn mean_neg_log(u0: f32, u1: f32, l0: f32, l1: f32) -> f32 {
    let e = (u1 - u0) / (u1 + u0);
    let e2 = e * e;
    let series = 0.5 * (l0 + l1) - e2 * (1.0 / 3.0 + e2 * (1.0 / 5.0 + e2 * (1.0 / 7.0)));
    // Both forms are computed and one selected (no branch: batches vectorise);
    // the unused one may be 0/0 when u0 == u1.
    let closed = (u1 * l1 - u0 * l0) / (u1 - u0) + 1.0;
    if e2 < 0.01 {
        series
    } else {
        closed
    }
}

/// One Simpson step: `u`, `λ`, `c` linear from end 0 to end 1, `k` unit distances.
#[inline(always)]
pub(super) fn sub_step(
    u0: f32,
    u1: f32,
    l0: f32,
    l1: f32,
    c0: [f32; 3],
    c1: [f32; 3],
    k: f32,
) -> Rgba {
    let um = 0.5 * (u0 + u1);
    let lm = -ln(um);
    let d_half = 0.5 * k * mean_neg_log(u0, um, l0, lm);
    let d = d_half + 0.5 * k * mean_neg_log(um, u1, lm, l1);
    let a_half = 1.0 - exp_neg(-d_half);
    let a = 1.0 - exp_neg(-d);
    // ∫ A dx by Simpson (A(0) = 0).
    let int_a = (4.0 * a_half + a) * (1.0 / 6.0);
    Rgba {
        rgb: [
            c1[0] * a - (c1[0] - c0[0]) * int_a,
            c1[1] * a - (c1[1] - c0[1]) * int_a,
            c1[2] * a - (c1[2] - c0[2]) * int_a,
        ],
        a,
    }
}
