//! Eight one-pixel cells at a time (AVX2): [`setup_tet`], the orthographic
//! face planes and the one pixel's test of [`ortho_segment`], lane by lane.
//!
//! A cell with one pixel centre is set up for that one pixel, so the set-up
//! is all of its cost, and its branches (the sorting network that makes
//! faces watertight, the sides of the faces) go either way at random: one
//! cell at a time it costs about as much as 100 ns. Here each lane runs
//! the scalar code's f32 operations in the same order (the same `mul`, `add`,
//! `sub`, `div` and `sqrt`, no fused multiply-add; comparisons become
//! masks and swaps blends), so each lane's numbers are the scalar code's,
//! bit for bit.
//!
//! One thing the lanes do in another order: the scalar code takes the
//! largest entering and the smallest leaving depth over the faces in the
//! order of the cell's vertex slots, the lanes in the order of the sorted
//! vertices. Without NaN, `max` and `min` do not depend on the order but
//! for the sign of a zero, and a zero cannot decide anything: the entry
//! depth is clamped to `+0`, and an exit depth of `±0` covers nothing either
//! way. A lane where a depth is NaN (planes of a face almost edge-on, in
//! overflowing coordinates) is flagged, and the caller redoes that cell with
//! the scalar code.
//!
//! [`setup_tet`]: super::setup::setup_tet
//! [`ortho_segment`]: super::scan::ortho_segment

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// Up to eight one-pixel cells, vertex data by slot then lane.
#[derive(Debug, Clone, Copy, Default)]
pub struct Lanes {
    /// Cells queued.
    pub n: usize,
    /// Vertex positions: `pos[slot][axis][lane]`.
    pub pos: [[[f32; 8]; 3]; 4],
    /// Global vertex ids: `ids[slot][lane]`.
    pub ids: [[u32; 8]; 4],
    /// Vertex scalars: `s[slot][lane]`.
    pub s: [[f32; 8]; 4],
    /// Smallest and largest vertex scalar (as [`super::setup::setup_tet`] folds them).
    pub s_min: [f32; 8],
    /// Largest vertex scalar.
    pub s_max: [f32; 8],
    /// The pixel centre.
    pub x: [f32; 8],
    /// The pixel centre's `y`.
    pub y: [f32; 8],
}

/// What the kernel found, lane by lane (bit `l` of a mask is lane `l`).
#[derive(Debug, Clone, Copy, Default)]
pub struct Found {
    /// Cells without volume.
    pub degenerate: u8,
    /// Cells to redo with the scalar code (a NaN depth).
    pub redo: u8,
    /// Covered pixels (of cells neither degenerate nor to redo).
    pub hit: u8,
    /// Entry depth.
    pub z_in: [f32; 8],
    /// Exit depth.
    pub z_out: [f32; 8],
    /// Scalar at entry.
    pub s_in: [f32; 8],
    /// Scalar at exit.
    pub s_out: [f32; 8],
}

/// A vector of three coordinates.
#[cfg(target_arch = "x86_64")]
type V3 = [__m256; 3];

/// Runs the lanes `0..lanes.n` (the others hold copies of lane 0's cell
/// or zeros and are ignored).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub unsafe fn one_pixel_x8(lanes: &Lanes) -> Found {
    let ld = |a: &[f32; 8]| _mm256_loadu_ps(a.as_ptr());
    let ldi = |a: &[u32; 8]| _mm256_loadu_si256(a.as_ptr() as *const __m256i);
    let add = |a: __m256, b: __m256| _mm256_add_ps(a, b);
    let sub = |a: __m256, b: __m256| _mm256_sub_ps(a, b);
    let mul = |a: __m256, b: __m256| _mm256_mul_ps(a, b);
    let and = |a: __m256, b: __m256| _mm256_and_ps(a, b);
    let or = |a: __m256, b: __m256| _mm256_or_ps(a, b);
    let not = |a: __m256| _mm256_xor_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(-1)));
    let gt = |a: __m256, b: __m256| _mm256_cmp_ps::<_CMP_GT_OQ>(a, b);
    let lt = |a: __m256, b: __m256| _mm256_cmp_ps::<_CMP_LT_OQ>(a, b);
    let le = |a: __m256, b: __m256| _mm256_cmp_ps::<_CMP_LE_OQ>(a, b);
    let eq = |a: __m256, b: __m256| _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b);
    let sel = |m: __m256, a: __m256, b: __m256| _mm256_blendv_ps(b, a, m);
    let set = |v: f32| _mm256_set1_ps(v);
    let v3sub = |a: V3, b: V3| [sub(a[0], b[0]), sub(a[1], b[1]), sub(a[2], b[2])];
    let cross = |a: V3, b: V3| {
        [
            sub(mul(a[1], b[2]), mul(a[2], b[1])),
            sub(mul(a[2], b[0]), mul(a[0], b[2])),
            sub(mul(a[0], b[1]), mul(a[1], b[0])),
        ]
    };
    let dot = |a: V3, b: V3| add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]));
    let abs = |a: __m256| _mm256_andnot_ps(set(-0.0), a);
    let finite = |a: __m256| lt(abs(a), set(f32::INFINITY));
    let (zero, inf, ninf) = (
        _mm256_setzero_ps(),
        set(f32::INFINITY),
        set(f32::NEG_INFINITY),
    );

    let p: [V3; 4] = std::array::from_fn(|k| {
        [
            ld(&lanes.pos[k][0]),
            ld(&lanes.pos[k][1]),
            ld(&lanes.pos[k][2]),
        ]
    });
    // Ids compared unsigned: flip the sign bit, compare signed.
    let flip = _mm256_set1_epi32(i32::MIN);
    let id: [__m256i; 4] = std::array::from_fn(|k| _mm256_xor_si256(ldi(&lanes.ids[k]), flip));

    // The sorting network of `setup_tet`: slot `a` after slot `b` by
    // position (x, y, z), then id; swapped by blends.
    let mut q = p;
    let mut qid = id;
    for (a, b) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
        let (pa, pb) = (q[a], q[b]);
        let gid = _mm256_castsi256_ps(_mm256_cmpgt_epi32(qid[a], qid[b]));
        let after = or(
            gt(pa[0], pb[0]),
            and(
                eq(pa[0], pb[0]),
                or(
                    gt(pa[1], pb[1]),
                    and(
                        eq(pa[1], pb[1]),
                        or(gt(pa[2], pb[2]), and(eq(pa[2], pb[2]), gid)),
                    ),
                ),
            ),
        );
        for c in 0..3 {
            q[a][c] = sel(after, pb[c], pa[c]);
            q[b][c] = sel(after, pa[c], pb[c]);
        }
        let ai = _mm256_castps_si256(after);
        let (ia, ib) = (qid[a], qid[b]);
        qid[a] = _mm256_blendv_epi8(ia, ib, ai);
        qid[b] = _mm256_blendv_epi8(ib, ia, ai);
    }
    let (e01, e02, e03) = (v3sub(q[1], q[0]), v3sub(q[2], q[0]), v3sub(q[3], q[0]));
    let faces: [(V3, V3); 4] = [
        (q[1], cross(v3sub(q[2], q[1]), v3sub(q[3], q[1]))),
        (q[0], cross(e02, e03)),
        (q[0], cross(e01, e03)),
        (q[0], cross(e01, e02)),
    ];
    let (x, y) = (ld(&lanes.x), ld(&lanes.y));
    let mut degenerate = zero;
    let mut redo = zero;
    let (mut z_in, mut z_out) = (ninf, inf);
    let (mut any_ent, mut any_ext, mut outside) = (zero, zero, zero);
    for (k, (a, n)) in faces.into_iter().enumerate() {
        let h = dot(n, a);
        let side = sub(dot(n, q[k]), h);
        degenerate = or(degenerate, or(eq(side, zero), not(finite(side))));
        // sigma = -1 where the side is positive (the normal points in).
        let neg = gt(side, zero);
        let sigma = sel(neg, set(-1.0), set(1.0));
        let edge_on = eq(n[2], zero);
        // Edge-on: inside iff sigma (n_x X + n_y Y) <= sigma h, ties by
        // `outside_edge_on`.
        let (ea, eb, ec) = (mul(sigma, n[0]), mul(sigma, n[1]), mul(sigma, h));
        let v = sub(add(mul(ea, x), mul(eb, y)), ec);
        let out_edge = or(
            gt(v, zero),
            and(
                eq(v, zero),
                or(lt(ea, zero), and(eq(ea, zero), le(eb, zero))),
            ),
        );
        outside = or(outside, and(edge_on, out_edge));
        // Otherwise a depth plane Z = a X + b Y + c.
        let pa = _mm256_div_ps(_mm256_xor_ps(n[0], set(-0.0)), n[2]);
        let pb = _mm256_div_ps(_mm256_xor_ps(n[1], set(-0.0)), n[2]);
        let pc = _mm256_div_ps(h, n[2]);
        let d = add(mul(pa, x), add(mul(pb, y), pc));
        let leaving = and(not(edge_on), gt(mul(sigma, n[2]), zero));
        let entering = and(not(edge_on), not(leaving));
        redo = or(redo, and(not(edge_on), _mm256_cmp_ps::<_CMP_UNORD_Q>(d, d)));
        z_in = _mm256_max_ps(z_in, sel(entering, d, ninf));
        z_out = _mm256_min_ps(z_out, sel(leaving, d, inf));
        any_ent = or(any_ent, entering);
        any_ext = or(any_ext, leaving);
    }
    // Depth is measured from the eye plane: nothing behind it is seen.
    let z_in = _mm256_max_ps(z_in, zero);
    let covered = and(and(any_ent, any_ext), and(lt(z_in, z_out), not(outside)));

    // The scalar gradient, from the unsorted slots.
    let (e1, e2, e3) = (v3sub(p[1], p[0]), v3sub(p[2], p[0]), v3sub(p[3], p[0]));
    let (c23, c31, c12) = (cross(e2, e3), cross(e3, e1), cross(e1, e2));
    let det = dot(e1, c23);
    let scale = _mm256_sqrt_ps(mul(mul(dot(e1, e1), dot(e2, e2)), dot(e3, e3)));
    degenerate = or(
        degenerate,
        or(not(gt(abs(det), mul(set(1e-6), scale))), not(finite(det))),
    );
    let s: [__m256; 4] = std::array::from_fn(|k| ld(&lanes.s[k]));
    let (d1, d2, d3) = (sub(s[1], s[0]), sub(s[2], s[0]), sub(s[3], s[0]));
    let inv = _mm256_div_ps(set(1.0), det);
    let g: [__m256; 3] = std::array::from_fn(|c| {
        mul(
            add(add(mul(d1, c23[c]), mul(d2, c31[c])), mul(d3, c12[c])),
            inv,
        )
    });
    let g_ok = and(and(finite(g[0]), finite(g[1])), finite(g[2]));
    let g = g.map(|c| and(c, g_ok));
    let s_row = add(s[0], mul(g[1], sub(y, p[0][1])));
    let s_xy = add(s_row, mul(g[0], sub(x, p[0][0])));
    let (s_min, s_max) = (ld(&lanes.s_min), ld(&lanes.s_max));
    let clamp = |v: __m256| _mm256_min_ps(_mm256_max_ps(v, s_min), s_max);
    let s_in = clamp(add(s_xy, mul(g[2], sub(z_in, p[0][2]))));
    let s_out = clamp(add(s_xy, mul(g[2], sub(z_out, p[0][2]))));

    let live = (1u32 << lanes.n) - 1;
    let bits = |m: __m256| (_mm256_movemask_ps(m) as u32 & live) as u8;
    let degenerate = bits(degenerate);
    let redo = bits(redo) & !degenerate;
    let mut found = Found {
        degenerate,
        redo,
        hit: bits(covered) & !degenerate & !redo,
        ..Found::default()
    };
    _mm256_storeu_ps(found.z_in.as_mut_ptr(), z_in);
    _mm256_storeu_ps(found.z_out.as_mut_ptr(), z_out);
    _mm256_storeu_ps(found.s_in.as_mut_ptr(), s_in);
    _mm256_storeu_ps(found.s_out.as_mut_ptr(), s_out);
    found
}
