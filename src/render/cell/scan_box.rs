//! The orthographic scan of one tet, eight pixel centres at a time (AVX2).
//!
//! [`super::scan::scan_ortho`] walks a cell row by row: per row it bounds the
//! covered span from the entering and leaving depth planes (a division per
//! plane pair), then tests each pixel of the span. Projected cells are small
//! (view B of the aorta: a 5 x 6 pixel bounding box, about 2.3 covered pixels
//! a row), so that per-row work cost more than the pixels it saved. This
//! kernel instead tests every pixel centre of the cell's bounding box
//! (clipped to the tile), taken eight at a time in row-major order, with no
//! per-row set-up at all, and appends the covered ones to the integration
//! batch with one permutation per output array.
//!
//! **Same segments, bit for bit.** Each lane evaluates the same f32
//! expressions in the same order as the scalar code (`a x + (b y + c)` per
//! plane, `max`/`min` with `maxps`/`minps`, whose "second operand unless
//! greater/less" rule is exactly [`super::fastmath::fmax`]/`fmin`), so the
//! depths, scalars and lengths are identical; the scalar code's span was a
//! conservative pre-filter (it never dropped a pixel the per-pixel test keeps),
//! so both produce the same set of segments. Only the order in which the
//! pixels of one cell enter the batch can differ, and that changes nothing:
//! lanes are integrated independently and each pixel's list still receives
//! its segments in cell order.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use super::integrate::BATCH;
use super::setup::TetSetup;
use super::target::ScanTarget;

/// Bounding boxes up to this many pixels take the vectorised kernel (so the
/// lane-to-pixel division below is exact, see [`scan_box_avx2`]).
pub const MAX_BOX_PIXELS: u32 = 1 << 16;

/// For each 8-bit mask, the indices of its set bits in order (then zeros):
/// the permutation that packs the selected lanes to the front.
static COMPRESS: [[i32; 8]; 256] = compress_table();

const fn compress_table() -> [[i32; 8]; 256] {
    let mut t = [[0i32; 8]; 256];
    let mut m = 0;
    while m < 256 {
        let (mut bit, mut k) = (0i32, 0usize);
        while bit < 8 {
            if m & (1 << bit) != 0 {
                t[m][k] = bit;
                k += 1;
            }
            bit += 1;
        }
        m += 1;
    }
    t
}

/// Scans the tet `t` over the pixel centres of `range = (i0, i1, j0, j1)`
/// (inclusive, inside `out.tile`, at most [`MAX_BOX_PIXELS`] of them) against
/// its entering planes `ent` and leaving planes `ext` (`Z = a X + b Y + c`,
/// unused slots at `-inf` / `+inf`; the tet has no edge-on face).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub unsafe fn scan_box_avx2(
    t: &TetSetup,
    ent: &[[f32; 3]; 3],
    ext: &[[f32; 3]; 3],
    range: (u32, u32, u32, u32),
    out: &mut ScanTarget,
) {
    let (i0, i1, j0, j1) = range;
    let w = i1 - i0 + 1;
    let total = w * (j1 - j0 + 1);
    debug_assert!(total <= MAX_BOX_PIXELS);
    let set = |v: f32| _mm256_set1_ps(v);
    let (ea, eb, ec) = (
        [set(ent[0][0]), set(ent[1][0]), set(ent[2][0])],
        [set(ent[0][1]), set(ent[1][1]), set(ent[2][1])],
        [set(ent[0][2]), set(ent[1][2]), set(ent[2][2])],
    );
    let (xa, xb, xc) = (
        [set(ext[0][0]), set(ext[1][0]), set(ext[2][0])],
        [set(ext[0][1]), set(ext[1][1]), set(ext[2][1])],
        [set(ext[0][2]), set(ext[1][2]), set(ext[2][2])],
    );
    let (g0, g1, g2) = (set(t.grad[0]), set(t.grad[1]), set(t.grad[2]));
    let (v0x, v0y, v0z) = (set(t.v0[0]), set(t.v0[1]), set(t.v0[2]));
    let (s0, s_min, s_max) = (set(t.s0), set(t.s_min), set(t.s_max));
    let (wf, inv_w, totalf) = (set(w as f32), set(1.0 / w as f32), set(total as f32));
    let (i0f, j0f, half, zero) = (
        set(i0 as f32),
        set(j0 as f32),
        set(0.5),
        _mm256_setzero_ps(),
    );
    // Tile-local index of the box's first pixel, and the tile's row pitch.
    let tile = out.tile;
    let base = _mm256_set1_epi32(((j0 - tile.y0) * tile.width() + (i0 - tile.x0)) as i32);
    let pitch = _mm256_set1_epi32(tile.width() as i32);
    let hint = _mm_set1_epi16(out.cell_piece as i16);
    let mut k = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
    let eight = set(8.0);
    let plane = |a: __m256, b: __m256, c: __m256, x: __m256, y: __m256| {
        _mm256_add_ps(_mm256_mul_ps(a, x), _mm256_add_ps(_mm256_mul_ps(b, y), c))
    };
    let mut covered = 0u64;
    let mut start = 0;
    // Each chunk stores eight lanes at `batch.n`: keep room for them.
    if out.pending.lanes.n > BATCH - 8 {
        out.flush();
    }
    while start < total {
        // Lane k is the box's pixel (k mod w, k div w). The quotient is
        // exact: (k + 1/2) / w is at least 1/(2w) from an integer, far
        // more than the rounding of (k + 1/2) * (1/w) for k < 2^16.
        let q = _mm256_floor_ps(_mm256_mul_ps(_mm256_add_ps(k, half), inv_w));
        let r = _mm256_sub_ps(k, _mm256_mul_ps(q, wf));
        let x = _mm256_add_ps(_mm256_add_ps(i0f, r), half);
        let y = _mm256_add_ps(_mm256_add_ps(j0f, q), half);
        let z_in = _mm256_max_ps(
            _mm256_max_ps(
                _mm256_max_ps(
                    plane(ea[0], eb[0], ec[0], x, y),
                    plane(ea[1], eb[1], ec[1], x, y),
                ),
                plane(ea[2], eb[2], ec[2], x, y),
            ),
            zero,
        );
        let z_out = _mm256_min_ps(
            _mm256_min_ps(
                plane(xa[0], xb[0], xc[0], x, y),
                plane(xa[1], xb[1], xc[1], x, y),
            ),
            plane(xa[2], xb[2], xc[2], x, y),
        );
        let inside = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_LT_OQ>(z_in, z_out),
            _mm256_cmp_ps::<_CMP_LT_OQ>(k, totalf),
        );
        let m = _mm256_movemask_ps(inside) as usize;
        k = _mm256_add_ps(k, eight);
        start += 8;
        if m == 0 {
            continue;
        }
        let s_row = _mm256_add_ps(s0, _mm256_mul_ps(g1, _mm256_sub_ps(y, v0y)));
        let s_xy = _mm256_add_ps(s_row, _mm256_mul_ps(g0, _mm256_sub_ps(x, v0x)));
        let clamp = |v: __m256| _mm256_min_ps(_mm256_max_ps(v, s_min), s_max);
        let s_in = clamp(_mm256_add_ps(
            s_xy,
            _mm256_mul_ps(g2, _mm256_sub_ps(z_in, v0z)),
        ));
        let s_out = clamp(_mm256_add_ps(
            s_xy,
            _mm256_mul_ps(g2, _mm256_sub_ps(z_out, v0z)),
        ));
        let len = _mm256_sub_ps(z_out, z_in);
        let idx = _mm256_add_epi32(
            base,
            _mm256_add_epi32(
                _mm256_mullo_epi32(_mm256_cvtps_epi32(q), pitch),
                _mm256_cvtps_epi32(r),
            ),
        );
        let perm = _mm256_loadu_si256(COMPRESS[m].as_ptr() as *const __m256i);
        let pack = |v: __m256| _mm256_permutevar8x32_ps(v, perm);
        let n = out.pending.lanes.n;
        // n <= BATCH - 8: the batch is flushed below before it gets closer.
        let b = &mut out.pending.lanes;
        _mm256_storeu_ps(b.s_in.as_mut_ptr().add(n), pack(s_in));
        _mm256_storeu_ps(b.s_out.as_mut_ptr().add(n), pack(s_out));
        _mm256_storeu_ps(b.len.as_mut_ptr().add(n), pack(len));
        _mm_storeu_si128(b.piece_hint.as_mut_ptr().add(n) as *mut __m128i, hint);
        _mm256_storeu_ps(out.pending.z_front.as_mut_ptr().add(n), pack(z_in));
        _mm256_storeu_ps(out.pending.z_back.as_mut_ptr().add(n), pack(z_out));
        _mm256_storeu_si256(
            out.pending.idx.as_mut_ptr().add(n) as *mut __m256i,
            _mm256_permutevar8x32_epi32(idx, perm),
        );
        let c = m.count_ones() as usize;
        covered += c as u64;
        out.pending.lanes.n = n + c;
        if n + c > BATCH - 8 {
            out.flush();
        }
    }
    out.counts.pixels_tested += covered;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compress_table_packs_set_bits_in_order() {
        assert_eq!(COMPRESS[0b1010_0110], [1, 2, 5, 7, 0, 0, 0, 0]);
        assert_eq!(COMPRESS[0xff], [0, 1, 2, 3, 4, 5, 6, 7]);
        assert_eq!(COMPRESS[0][0], 0);
    }
}
