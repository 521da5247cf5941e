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
    /// Set by [`PreparedTf::integrate_batch`]: pieces the exact integrator
    /// cut the lanes that cross control points (or need sub-steps) into.
    pub pieces: u32,
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
            pieces: 0,
            lanes: Lanes {
                split: [false; BATCH],
                piece: [0; BATCH],
                tasks: Tasks::default(),
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
}

/// Per lane: its transfer-function piece, and whether the scalar code must
/// redo it.
#[derive(Debug, Clone)]
struct Lanes {
    split: [bool; BATCH],
    /// Always a valid index into the pieces (lanes past `n` keep an old one).
    piece: [u32; BATCH],
    /// Pass 3's work: the pieces of the lanes that cross control points.
    tasks: Tasks,
}

impl PreparedTf {
    /// Integrates the first `b.n` lanes of `b` into `b.rgba`. Same results as
    /// [`PreparedTf::integrate`] lane by lane, up to f32 rounding.
    ///
    /// Three passes, each a simple loop over lanes so that the compiler can
    /// vectorise the first and the last: find each lane's piece (a branch-free
    /// count of control points at or below the scalar), gather that piece's
    /// parameters, then do the math. Lanes that cross a control point or need
    /// sub-steps are redone: cut into pieces at the control points, the
    /// pieces of all such lanes integrated together (vectorised, bit for bit
    /// the scalar [`PreparedTf::exact`]).
    pub fn integrate_batch(&self, integrator: Integrator, b: &mut Batch) {
        let lanes = ((b.n + 7) & !7).min(BATCH);
        let (inv_ud, exact) = (self.inv_unit_distance, integrator == Integrator::Exact);
        b.pieces = 0;
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
            // Pass 3: lanes that cross a control point or need sub-steps, cut
            // at the points into one task per piece (one task if they cross
            // none), the tasks integrated together (vectorised), then
            // composited per lane in order.
            let tasks = &mut b.lanes.tasks;
            tasks.clear();
            for l in 0..b.n {
                if b.lanes.split[l] {
                    self.cuts(b.s_in[l], b.s_out[l], b.len[l], tasks);
                    tasks.ends.push((l as u16, tasks.piece.len() as u32));
                }
            }
            b.pieces = tasks.piece.len() as u32;
            if !tasks.ends.is_empty() {
                #[cfg(target_arch = "x86_64")]
                {
                    if std::arch::is_x86_feature_detected!("avx2") {
                        // SAFETY: the CPU supports AVX2, checked just above.
                        unsafe { tasks_avx2(tasks, &self.table, omax_f32()) };
                    } else {
                        tasks_lanes(tasks, &self.table, omax_f32());
                    }
                }
                #[cfg(not(target_arch = "x86_64"))]
                tasks_lanes(tasks, &self.table, omax_f32());
                let mut start = 0;
                for e in 0..tasks.ends.len() {
                    let (l, end) = tasks.ends[e];
                    let end = end as usize;
                    // As `exact`: one piece is its result, several are
                    // composited over CLEAR in order.
                    let acc = if end - start == 1 {
                        tasks.out[start]
                    } else {
                        let mut acc = Rgba::CLEAR;
                        for q in start..end {
                            acc = acc.over(tasks.out[q]);
                        }
                        acc
                    };
                    start = end;
                    let l = l as usize;
                    b.rgba[0][l] = acc.rgb[0];
                    b.rgba[1][l] = acc.rgb[1];
                    b.rgba[2][l] = acc.rgb[2];
                    b.rgba[3][l] = acc.a;
                }
            }
        }
    }

    /// The cuts [`PreparedTf::exact`] makes of a segment that crosses
    /// control points, as tasks (piece, scalar at both ends, unit distances),
    /// in the order it composites them.
    #[inline]
    fn cuts(&self, s_a: f32, s_b: f32, length: f32, tasks: &mut Tasks) {
        let k = length * self.inv_unit_distance;
        let (i_a, i_b) = (self.piece_index(s_a), self.piece_index(s_b));
        let inv_ds = 1.0 / (s_b - s_a);
        let (mut s_prev, mut x_prev) = (s_a, 0.0f32);
        let mut cut = |i: usize, s_next: f32, x_next: f32| {
            tasks.push(i as u32, s_prev, s_next, k * (x_next - x_prev));
            s_prev = s_next;
            x_prev = x_next;
        };
        if i_a == i_b {
            // A lane that needs sub-steps within one piece: one task.
            cut(i_a, s_b, 1.0);
        } else if i_b > i_a {
            for i in i_a..i_b {
                let s = self.breaks[i];
                cut(i, s, (s - s_a) * inv_ds);
            }
            cut(i_b, s_b, 1.0);
        } else {
            for i in (i_b + 1..=i_a).rev() {
                let s = self.breaks[i - 1];
                cut(i, s, (s - s_a) * inv_ds);
            }
            cut(i_b, s_b, 1.0);
        }
    }
}

fn omax_f32() -> f32 {
    OPACITY_MAX as f32
}

/// Pieces of crossing lanes to integrate (structure of arrays), and per
/// crossing lane its batch lane and one past its last task.
#[derive(Debug, Clone, Default)]
pub(super) struct Tasks {
    piece: Vec<u32>,
    s0: Vec<f32>,
    s1: Vec<f32>,
    k: Vec<f32>,
    out: Vec<Rgba>,
    ends: Vec<(u16, u32)>,
}

impl Tasks {
    fn clear(&mut self) {
        self.piece.clear();
        self.s0.clear();
        self.s1.clear();
        self.k.clear();
        self.out.clear();
        self.ends.clear();
    }
    #[inline(always)]
    fn push(&mut self, piece: u32, s0: f32, s1: f32, k: f32) {
        self.piece.push(piece);
        self.s0.push(s0);
        self.s1.push(s1);
        self.k.push(k);
    }
}

/// [`tasks_lanes`] compiled for AVX2 (no FMA, as [`math_avx2`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
unsafe fn tasks_avx2(tasks: &mut Tasks, t: &PieceTable, omax: f32) {
    tasks_lanes(tasks, t, omax)
}

/// Lanes of a task group.
const W: usize = 8;

/// `PreparedTf::piece` for every task, eight at a time: the same operations
/// in the same order as the scalar code (transparent pieces give CLEAR, one
/// sub-step its Simpson step, more the sub-step loop), so the results are
/// bit for bit the scalar ones. A group runs the loop to its largest step
/// count; a lane past its own count keeps its result (a select).
// Lane loops index several arrays in step: written for the vectoriser.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn tasks_lanes(tasks: &mut Tasks, t: &PieceTable, omax: f32) {
    let m = tasks.piece.len();
    tasks.out.resize(m, Rgba::CLEAR);
    let np = t.s0.len();
    // SAFETY: task pieces come from `piece_index`, below the piece count.
    let at = |v: &[f32], i: u32| -> f32 {
        debug_assert!((i as usize) < np && v.len() == np);
        unsafe { *v.get_unchecked(i as usize) }
    };
    for base in (0..m).step_by(W) {
        let real = (m - base).min(W);
        let mut piece = [0u32; W];
        let mut s0 = [0.0f32; W];
        let mut s1 = [0.0f32; W];
        let mut kk = [0.0f32; W];
        piece[..real].copy_from_slice(&tasks.piece[base..base + real]);
        s0[..real].copy_from_slice(&tasks.s0[base..base + real]);
        s1[..real].copy_from_slice(&tasks.s1[base..base + real]);
        kk[..real].copy_from_slice(&tasks.k[base..base + real]);
        let mut u0 = [0.0f32; W];
        let mut u1 = [0.0f32; W];
        let mut l1 = [0.0f32; W];
        let mut c0 = [[0.0f32; W]; 3];
        let mut c1 = [[0.0f32; W]; 3];
        let mut nf = [0.0f32; W];
        let mut kn = [0.0f32; W];
        let mut inv_n = [0.0f32; W];
        let mut ua = [0.0f32; W];
        let mut la = [0.0f32; W];
        let mut ca = [[0.0f32; W]; 3];
        let mut one = [[0.0f32; W]; 4];
        let mut clear = [false; W];
        for l in 0..W {
            let i = piece[l];
            let (p0, inv_w, o0, d_o) = (at(&t.s0, i), at(&t.inv_w, i), at(&t.o0, i), at(&t.d_o, i));
            let k = kk[l];
            let w0 = fclamp((s0[l] - p0) * inv_w, 0.0, 1.0);
            let w1 = fclamp((s1[l] - p0) * inv_w, 0.0, 1.0);
            let a0 = 1.0 - fmin(o0 + d_o * w0, omax);
            let a1 = 1.0 - fmin(o0 + d_o * w1, omax);
            clear[l] = a0 >= 1.0 && a1 >= 1.0;
            let (m0, m1) = (-ln(a0), -ln(a1));
            let d_est = k * fmax(m0, m1);
            let rel = (a1 - a0).abs() / fmin(a0, a1);
            let steps = fclamp(fmax(d_est * 2.5, rel * 3.0).ceil(), 1.0, 64.0);
            let mut e0 = [0.0f32; 3];
            let mut e1 = [0.0f32; 3];
            for c in 0..3 {
                let (c0p, d_c) = (at(&t.c0[c], i), at(&t.d_c[c], i));
                e0[c] = c0p + d_c * w0;
                e1[c] = c0p + d_c * w1;
                c0[c][l] = e0[c];
                c1[c][l] = e1[c];
                ca[c][l] = e0[c];
            }
            let v = sub_step(a0, a1, m0, m1, e0, e1, k);
            one[0][l] = v.rgb[0];
            one[1][l] = v.rgb[1];
            one[2][l] = v.rgb[2];
            one[3][l] = v.a;
            u0[l] = a0;
            u1[l] = a1;
            l1[l] = m1;
            nf[l] = steps;
            inv_n[l] = 1.0 / steps;
            kn[l] = k * inv_n[l];
            ua[l] = a0;
            la[l] = m0;
        }
        let steps = nf[..real].iter().fold(1.0f32, |a, &b| fmax(a, b)) as usize;
        let mut acc = [[0.0f32; W]; 4];
        if steps > 1 {
            for j in 1..=steps {
                let jf = j as f32;
                for l in 0..W {
                    let x = jf * inv_n[l];
                    let ub = u0[l] + (u1[l] - u0[l]) * x;
                    let cb = [
                        c0[0][l] + (c1[0][l] - c0[0][l]) * x,
                        c0[1][l] + (c1[1][l] - c0[1][l]) * x,
                        c0[2][l] + (c1[2][l] - c0[2][l]) * x,
                    ];
                    let lb = if jf == nf[l] { l1[l] } else { -ln(ub) };
                    let v = sub_step(
                        ua[l],
                        ub,
                        la[l],
                        lb,
                        [ca[0][l], ca[1][l], ca[2][l]],
                        cb,
                        kn[l],
                    );
                    let a = Rgba {
                        rgb: [acc[0][l], acc[1][l], acc[2][l]],
                        a: acc[3][l],
                    }
                    .over(v);
                    if jf <= nf[l] {
                        acc[0][l] = a.rgb[0];
                        acc[1][l] = a.rgb[1];
                        acc[2][l] = a.rgb[2];
                        acc[3][l] = a.a;
                        ua[l] = ub;
                        la[l] = lb;
                        ca[0][l] = cb[0];
                        ca[1][l] = cb[1];
                        ca[2][l] = cb[2];
                    }
                }
            }
        }
        for l in 0..real {
            tasks.out[base + l] = if clear[l] {
                Rgba::CLEAR
            } else if nf[l] == 1.0 {
                Rgba {
                    rgb: [one[0][l], one[1][l], one[2][l]],
                    a: one[3][l],
                }
            } else {
                Rgba {
                    rgb: [acc[0][l], acc[1][l], acc[2][l]],
                    a: acc[3][l],
                }
            };
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
// Lane loops index several arrays in step: written for the vectoriser.
#[allow(clippy::needless_range_loop)]
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
