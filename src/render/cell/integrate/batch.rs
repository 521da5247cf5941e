//! Batched integration: segments as structure-of-arrays lanes, so the
//! common case (a tet within one transfer-function piece) vectorises.

use super::*;

/// Lanes in an integration batch.
pub const BATCH: usize = 128;

/// `Batch::piece_hint` value meaning "look the piece up".
pub const NO_PIECE: u16 = u16::MAX;

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
        let (inv_ud, exact) = (self.inv_unit_distance, integrator == Integrator::Exact);
        // Pass 1: each lane's piece; a lane whose ends lie in different
        // pieces crosses a control point and is split later. With few
        // control points, a vectorised count of the points at or below each
        // end (the same index as `piece_index`); else the look-up table.
        let counted = self.breaks.len() <= COUNTED_BREAKS;
        if !counted {
            for l in 0..b.n {
                let hint = b.piece_hint[l];
                let (i, split) = match integrator {
                    _ if hint != NO_PIECE => (hint as usize, false),
                    Integrator::Exact => {
                        let i = self.piece_index(b.s_in[l]);
                        (i, i != self.piece_index(b.s_out[l]))
                    }
                    Integrator::Midpoint => {
                        (self.piece_index(0.5 * (b.s_in[l] + b.s_out[l])), false)
                    }
                };
                b.lanes.split[l] = split;
                b.lanes.piece[l] = i.min(self.pieces.len() - 1) as u32;
            }
        }
        // Pass 2 (vectorised): the math, on whole vectors of lanes (lanes past
        // `n` hold stale inputs; their results are ignored).
        let breaks: &[f32] = if counted { &self.breaks } else { &[] };
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2, checked just above.
                unsafe { math_avx2(b, &self.table, breaks, counted, lanes, inv_ud, exact) };
            } else {
                if counted {
                    pieces_by_count(b, breaks, lanes, exact);
                }
                math_lanes(b, &self.table, lanes, inv_ud, exact);
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            if counted {
                pieces_by_count(b, breaks, lanes, exact);
            }
            math_lanes(b, &self.table, lanes, inv_ud, exact);
        }
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
unsafe fn math_avx2(
    b: &mut Batch,
    t: &PieceTable,
    breaks: &[f32],
    counted: bool,
    lanes: usize,
    inv_ud: f32,
    exact: bool,
) {
    // Two calls, not one loop nest: inlined together, the math loop no
    // longer vectorised (5x the instructions).
    if counted {
        pieces_avx2(b, breaks, lanes, exact);
    }
    math_lanes(b, t, lanes, inv_ud, exact)
}

/// [`pieces_by_count`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
unsafe fn pieces_avx2(b: &mut Batch, breaks: &[f32], lanes: usize, exact: bool) {
    pieces_by_count(b, breaks, lanes, exact)
}

/// Control points up to which pass 1 counts (vectorised) instead of using
/// the look-up table.
const COUNTED_BREAKS: usize = 16;

/// Pass 1 by counting: a lane's piece is the number of control points at or
/// below its scalar (`breaks` ascending), which is what
/// [`PreparedTf::piece_index`] returns; lanes with a hint keep it. Every
/// lane up to `lanes` gets a valid piece (at most `breaks.len()`).
#[inline(always)]
fn pieces_by_count(b: &mut Batch, breaks: &[f32], lanes: usize, exact: bool) {
    let mut ia = [0u32; BATCH];
    let mut ib = [0u32; BATCH];
    if exact {
        for &br in breaks {
            for l in 0..lanes {
                ia[l] += (br <= b.s_in[l]) as u32;
                ib[l] += (br <= b.s_out[l]) as u32;
            }
        }
    } else {
        for &br in breaks {
            for l in 0..lanes {
                ia[l] += (br <= 0.5 * (b.s_in[l] + b.s_out[l])) as u32;
            }
        }
        ib = ia;
    }
    for l in 0..lanes {
        let hint = b.piece_hint[l];
        let free = hint == NO_PIECE;
        b.lanes.split[l] = free && ia[l] != ib[l];
        b.lanes.piece[l] = if free { ia[l] } else { hint as u32 };
    }
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
