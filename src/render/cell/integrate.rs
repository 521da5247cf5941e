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
use super::segment::Rgba;
use crate::scene::transfer::{TransferFunction, OPACITY_MAX};

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
            pieces,
            inv_unit_distance: (1.0 / tf.unit_distance) as f32,
        }
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

/// Lanes in an integration batch.
pub const BATCH: usize = 128;

/// `Batch::piece_hint` value meaning "look the piece up".
pub const NO_PIECE: u16 = u16::MAX;

/// Cells of the piece lookup table.
const LUT: usize = 1024;

/// Segments to integrate together, structure of arrays, so the common case
/// (every segment of a tet within one transfer-function piece) runs as one
/// vectorised loop.
#[derive(Debug, Clone)]
pub struct Batch {
    /// Lanes in use.
    pub n: usize,
    /// Scalar at entry.
    pub s_in: [f32; BATCH],
    /// Scalar at exit.
    pub s_out: [f32; BATCH],
    /// Length in world units.
    pub len: [f32; BATCH],
    /// Results: premultiplied red, green, blue and alpha.
    pub rgba: [[f32; BATCH]; 4],
    /// Per lane, the transfer-function piece holding both ends if the caller
    /// knows it (the whole cell's scalar range lies in one piece), else
    /// [`NO_PIECE`].
    pub piece_hint: [u16; BATCH],
    /// Scratch: each lane's transfer-function piece, gathered.
    lanes: Lanes,
}

impl Default for Batch {
    fn default() -> Self {
        Batch {
            n: 0,
            s_in: [0.0; BATCH],
            s_out: [0.0; BATCH],
            len: [0.0; BATCH],
            rgba: [[0.0; BATCH]; 4],
            piece_hint: [NO_PIECE; BATCH],
            lanes: Lanes {
                split: [false; BATCH],
                piece: [0; BATCH],
            },
        }
    }
}

impl Batch {
    /// The result of lane `i`.
    #[inline(always)]
    pub fn result(&self, i: usize) -> Rgba {
        Rgba {
            rgb: [self.rgba[0][i], self.rgba[1][i], self.rgba[2][i]],
            a: self.rgba[3][i],
        }
    }
    #[inline(always)]
    fn set(&mut self, i: usize, v: Rgba) {
        self.rgba[0][i] = v.rgb[0];
        self.rgba[1][i] = v.rgb[1];
        self.rgba[2][i] = v.rgb[2];
        self.rgba[3][i] = v.a;
    }
}

/// Per lane: its transfer-function piece, and whether the scalar code must
/// redo it.
#[derive(Debug, Clone)]
struct Lanes {
    split: [bool; BATCH],
    /// Always a valid index into the pieces (lanes past `n` keep an old one).
    piece: [u32; BATCH],
}

impl PreparedTf {
    /// Integrates the first `b.n` lanes of `b` into `b.rgba`. Same results as
    /// [`PreparedTf::integrate`] lane by lane, up to f32 rounding.
    ///
    /// Three passes, each a simple loop over lanes so that the compiler can
    /// vectorise the first and the last: find each lane's piece (a branch-free
    /// count of control points at or below the scalar), gather that piece's
    /// parameters, then do the math. Lanes that cross a control point or need
    /// sub-steps are redone one by one by the scalar code.
    pub fn integrate_batch(&self, integrator: Integrator, b: &mut Batch) {
        let lanes = ((b.n + 7) & !7).min(BATCH);
        // Pass 1 (scalar): each lane's piece; a lane whose ends lie in
        // different pieces crosses a control point and is split later.
        for l in 0..b.n {
            let hint = b.piece_hint[l];
            let (i, split) = match integrator {
                _ if hint != NO_PIECE => (hint as usize, false),
                Integrator::Exact => {
                    let i = self.piece_index(b.s_in[l]);
                    (i, i != self.piece_index(b.s_out[l]))
                }
                Integrator::Midpoint => (self.piece_index(0.5 * (b.s_in[l] + b.s_out[l])), false),
            };
            b.lanes.split[l] = split;
            b.lanes.piece[l] = i.min(self.pieces.len() - 1) as u32;
        }
        // Pass 2 (vectorised): the math, on whole vectors of lanes (lanes past
        // `n` hold stale inputs; their results are ignored).
        let (inv_ud, exact) = (self.inv_unit_distance, integrator == Integrator::Exact);
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2, checked just above.
                unsafe { math_avx2(b, &self.table, lanes, inv_ud, exact) };
            } else {
                math_lanes(b, &self.table, lanes, inv_ud, exact);
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        math_lanes(b, &self.table, lanes, inv_ud, exact);
        if exact {
            // Pass 3 (scalar, rare): lanes that cross a control point or need sub-steps.
            for l in 0..b.n {
                if b.lanes.split[l] {
                    let v = self.exact(b.s_in[l], b.s_out[l], b.len[l]);
                    b.set(l, v);
                }
            }
        }
    }
}

/// Pass 2 compiled for AVX2 (eight lanes per instruction). No FMA: the
/// results are bit-identical to the SSE2 build, so images do not depend on
/// the machine.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn math_avx2(b: &mut Batch, t: &PieceTable, lanes: usize, inv_ud: f32, exact: bool) {
    math_lanes(b, t, lanes, inv_ud, exact)
}

/// Pass 2 of [`PreparedTf::integrate_batch`]: per lane, the exact sub-step
/// (or the midpoint rule) from the gathered piece parameters.
#[inline(always)]
fn math_lanes(b: &mut Batch, t: &PieceTable, lanes: usize, inv_ud: f32, exact: bool) {
    let omax = OPACITY_MAX as f32;
    let g = &mut b.lanes;
    // A lane's piece parameter `v[piece]`. SAFETY: `Lanes::piece` only ever
    // holds indices below the number of pieces (set from `piece_index` and
    // clamped in pass 1, zero-initialised), and every column has that length.
    // Unchecked, so the loops below vectorise with gathers.
    let n = t.s0.len();
    let at = |v: &[f32], i: u32| -> f32 {
        debug_assert!((i as usize) < n && v.len() == n);
        unsafe { *v.get_unchecked(i as usize) }
    };
    if exact {
        for l in 0..lanes {
            let i = g.piece[l];
            let (s0, inv_w, o0, d_o) = (at(&t.s0, i), at(&t.inv_w, i), at(&t.o0, i), at(&t.d_o, i));
            let c0p = [at(&t.c0[0], i), at(&t.c0[1], i), at(&t.c0[2], i)];
            let d_c = [at(&t.d_c[0], i), at(&t.d_c[1], i), at(&t.d_c[2], i)];
            let k = b.len[l] * inv_ud;
            let w0 = fclamp((b.s_in[l] - s0) * inv_w, 0.0, 1.0);
            let w1 = fclamp((b.s_out[l] - s0) * inv_w, 0.0, 1.0);
            let u0 = 1.0 - fmin(o0 + d_o * w0, omax);
            let u1 = 1.0 - fmin(o0 + d_o * w1, omax);
            let (l0, l1) = (-ln(u0), -ln(u1));
            let d_est = k * fmax(l0, l1);
            let rel = (u1 - u0).abs() / fmin(u0, u1);
            g.split[l] |= d_est * 2.5 > 1.0 || rel * 3.0 > 1.0;
            let c0 = [
                c0p[0] + d_c[0] * w0,
                c0p[1] + d_c[1] * w0,
                c0p[2] + d_c[2] * w0,
            ];
            let c1 = [
                c0p[0] + d_c[0] * w1,
                c0p[1] + d_c[1] * w1,
                c0p[2] + d_c[2] * w1,
            ];
            let v = sub_step(u0, u1, l0, l1, c0, c1, k);
            b.rgba[0][l] = v.rgb[0];
            b.rgba[1][l] = v.rgb[1];
            b.rgba[2][l] = v.rgb[2];
            b.rgba[3][l] = v.a;
        }
    } else {
        for l in 0..lanes {
            let i = g.piece[l];
            let k = b.len[l] * inv_ud;
            let w = fclamp(
                (0.5 * (b.s_in[l] + b.s_out[l]) - at(&t.s0, i)) * at(&t.inv_w, i),
                0.0,
                1.0,
            );
            let o = fmin(at(&t.o0, i) + at(&t.d_o, i) * w, omax);
            let a = 1.0 - exp_neg(k * ln(1.0 - o));
            for c in 0..3 {
                b.rgba[c][l] = (at(&t.c0[c], i) + at(&t.d_c[c], i) * w) * a;
            }
            b.rgba[3][l] = a;
        }
    }
}

/// `∫_0^1 -ln(u(x)) dx` for `u` linear from `u0` to `u1`, given `λ = -ln u` at
/// both ends. Exact form `(u1 λ1 - u0 λ0) / (u1 - u0) + 1`; when the ends are
/// close, the series `(λ0 + λ1)/2 - Σ_{n≥1} e^{2n} / (2n + 1)` with
/// `e = (u1 - u0) / (u1 + u0)` (from `artanh(e)/e`), which avoids the cancellation.
#[inline(always)]
fn mean_neg_log(u0: f32, u1: f32, l0: f32, l1: f32) -> f32 {
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
fn sub_step(u0: f32, u1: f32, l0: f32, l1: f32, c0: [f32; 3], c1: [f32; 3], k: f32) -> Rgba {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::transfer::ControlPoint;

    fn aorta_tf() -> TransferFunction {
        let pts = [
            [0.0000, 0.2300, 0.2990, 0.7540, 0.0000],
            [0.0400, 0.2815, 0.3616, 0.7927, 0.2094],
            [0.1000, 0.3588, 0.4554, 0.8508, 0.6979],
            [0.2400, 0.5391, 0.6744, 0.9863, 0.6979],
            [0.2500, 0.5520, 0.6900, 0.9960, 0.6595],
            [0.3400, 0.6647, 0.7530, 0.9488, 0.3141],
            [0.5000, 0.8650, 0.8650, 0.8650, 0.0838],
            [0.7500, 0.9580, 0.6040, 0.4820, 0.1256],
            [1.0000, 0.7060, 0.0160, 0.1500, 0.2443],
        ];
        TransferFunction::from_rows(&pts, 5.0)
    }

    /// Brute-force f64 integral: many small steps, each with the exact
    /// constant-extinction formula at its midpoint, composited.
    fn brute(tf: &TransferFunction, sa: f64, sb: f64, len: f64) -> (f64, [f64; 3]) {
        let n = 20_000;
        let (mut t, mut c) = (1.0f64, [0.0f64; 3]);
        for i in 0..n {
            let x = (i as f64 + 0.5) / n as f64;
            let s = sa + (sb - sa) * x;
            let (rgb, _) = tf.eval(s);
            let a = 1.0 - (-tf.extinction(s) * len / n as f64).exp();
            for k in 0..3 {
                c[k] += t * a * rgb[k];
            }
            t *= 1.0 - a;
        }
        (1.0 - t, c)
    }

    #[test]
    fn exact_is_within_1e4_of_the_true_integral() {
        let tf = aorta_tf();
        let p = PreparedTf::new(&tf);
        let mut worst = 0.0f64;
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..3000 {
            let sa = rnd() * 1.1 - 0.05;
            let sb = if rnd() < 0.5 {
                sa + (rnd() - 0.5) * 0.1
            } else {
                rnd() * 1.1 - 0.05
            };
            let len = [0.01, 0.5, 2.0, 10.0, 40.0][(rnd() * 5.0) as usize % 5] * rnd();
            let got = p.exact(sa as f32, sb as f32, len as f32);
            let (a, c) = brute(&tf, sa, sb, len);
            let err = (got.a as f64 - a).abs().max(
                (0..3)
                    .map(|k| (got.rgb[k] as f64 - c[k]).abs())
                    .fold(0.0, f64::max),
            );
            worst = worst.max(err);
            assert!(
                err < 1e-4,
                "sa={sa} sb={sb} len={len}: got {got:?}, want a={a} c={c:?}, err {err}"
            );
        }
        eprintln!("worst exact error {worst:e}");
    }

    #[test]
    fn opacity_one_and_zero_length_are_finite() {
        let tf = TransferFunction {
            points: vec![
                ControlPoint {
                    s: 0.0,
                    rgb: [1.0, 0.5, 0.0],
                    opacity: 1.0,
                },
                ControlPoint {
                    s: 1.0,
                    rgb: [1.0, 0.5, 0.0],
                    opacity: 1.0,
                },
            ],
            unit_distance: 1.0,
        };
        let p = PreparedTf::new(&tf);
        for integ in [Integrator::Exact, Integrator::Midpoint] {
            let r = p.integrate(integ, 0.2, 0.8, 3.0);
            assert!(
                r.a > 0.999_999 && r.a <= 1.0 && r.rgb.iter().all(|v| v.is_finite()),
                "{r:?}"
            );
            let z = p.integrate(integ, 0.2, 0.8, 0.0);
            assert_eq!(z.a, 0.0);
        }
    }

    /// The definition: zero opacity at both ends and at every control point
    /// between them (the opacity is linear in between).
    fn transparent_by_definition(p: &PreparedTf, lo: f32, hi: f32) -> bool {
        if p.eval(lo).0 > 0.0 || p.eval(hi).0 > 0.0 {
            return false;
        }
        let (i0, i1) = (p.piece_index(lo), p.piece_index(hi));
        (i0..i1).all(|b| p.pieces[b + 1].o0 <= 0.0)
    }

    proptest::proptest! {
        #[test]
        fn zero_runs_agree_with_the_definition(
            ops in proptest::collection::vec(0u8..4, 2..9),
            cuts in proptest::collection::vec(0.0f64..1.0, 2..9),
            queries in proptest::collection::vec((-0.2f32..1.2, 0.0f32..0.5), 1..60),
        ) {
            // Control points at sorted positions (duplicates allowed), with
            // opacity 0 half of the time so zero runs of every shape occur.
            let n = ops.len().min(cuts.len());
            let mut s: Vec<f64> = cuts[..n].to_vec();
            s.sort_by(|a, b| a.total_cmp(b));
            let points = (0..n)
                .map(|i| ControlPoint {
                    s: s[i],
                    rgb: [0.5, 0.5, 0.5],
                    opacity: [0.0, 0.0, 0.3, 1.0][ops[i] as usize],
                })
                .collect();
            let p = PreparedTf::new(&TransferFunction { points, unit_distance: 1.0 });
            // Also ask about the control points themselves.
            let mut qs = queries.clone();
            qs.extend(s.iter().map(|&v| (v as f32, 0.0)));
            for (lo, w) in qs {
                let hi = lo + w;
                proptest::prop_assert_eq!(
                    p.is_transparent(lo, hi),
                    transparent_by_definition(&p, lo, hi),
                    "[{}, {}] with {:?}", lo, hi, p.zero_runs
                );
            }
        }
    }

    #[test]
    fn transparent_intervals() {
        let p = PreparedTf::new(&aorta_tf());
        assert!(p.is_transparent(-1.0, 0.0));
        assert!(!p.is_transparent(-1.0, 0.01));
        assert!(!p.is_transparent(0.3, 0.31));
    }
}
