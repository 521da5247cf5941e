//! How a run of one splat's alphas enters the accumulation buffer, and the
//! occlusion map of early splat elimination (Mueller, Möller & Crawfis
//! 1999).
//!
//! Premultiplied RGBA `(C, A)` per pixel; a splat of colour `c` and alpha
//! `alpha` at a pixel:
//!
//! - [`Over`], back to front (the splat in front of what is there):
//!   `C <- c alpha + (1 - alpha) C`, `A <- alpha + (1 - alpha) A`;
//! - [`Under`], front to back (the splat behind what is there):
//!   `C <- C + (1 - A) alpha c`, `A <- A + (1 - A) alpha`. Both give the same
//!   image up to f32 rounding (the operator is associative).
//!
//! **Early splat elimination.** Front to back, a pixel whose `A` has reached
//! the threshold `t` (`--ert`) can take at most `1 - A <= 1 - t` more light.
//! [`Under`] counts, per 8 x 8 tile of the band, the pixels still below `t`
//! ([`OcclusionMap`]); a splat whose bounding rectangle lies in tiles with
//! none left is skipped without rasterising. Error: at a pixel, let `T` be
//! the transmittance `1 - A` when the first splat was skipped there (`T <=
//! 1 - t`); the exact and the ERT image are both `C_front + T X` with `X`
//! the composite of everything behind (background included), which lies in
//! `[0, M]` per channel, `M = max(max TF radiance, max background)`. So
//! every channel differs by at most `(1 - t) M`, the slicers' ERT bound
//! (`SliceStats::ert_bound`) with the background added.

use super::buffer::{BandBuf, Lanes, LANES};

/// Tile side of the occlusion map, pixels.
pub const TILE: usize = 8;

/// How a splat's alphas enter the band.
pub trait Composite {
    /// Composites the first `n` of `alpha` (one per pixel) of colour `rgb`
    /// into pixels `i0 .. i0 + n` of band-local row `r` of `buf`. `alpha`
    /// must hold `n` rounded up to [`LANES`] values (those past `n` are
    /// read and ignored), so that every run is whole vectors.
    #[inline(always)]
    fn run(
        &mut self,
        buf: &mut BandBuf,
        r: usize,
        i0: usize,
        alpha: &[f32],
        n: usize,
        rgb: [f32; 3],
    ) {
        let c = [rgb[0], rgb[1], rgb[2], 1.0];
        let mut k = 0;
        while k < n {
            // LANES alphas; lanes past the run get 0 and leave their
            // pixels as they are ([`super::buffer`]).
            let v: &[f32; LANES] = alpha[k..k + LANES].try_into().expect("padded alphas");
            let m = n - k;
            let mut a8 = [0.0f32; LANES];
            for (l, (a, &x)) in a8.iter_mut().zip(v).enumerate() {
                *a = if l < m { x } else { 0.0 };
            }
            self.lanes(buf.lanes(r, i0 + k), r, i0 + k, &a8, c);
            k += LANES;
        }
    }

    /// Composites [`LANES`] alphas `a` of colour `c` (`c[3] = 1`) into the
    /// pixels `i ..` of band-local row `r`.
    fn lanes(&mut self, px: Lanes, r: usize, i: usize, a: &[f32; LANES], c: [f32; 4]);
}

/// Back to front: the splat in front of the pixel.
#[derive(Debug, Clone, Copy, Default)]
pub struct Over;

impl Composite for Over {
    #[inline(always)]
    fn lanes(&mut self, px: Lanes, _r: usize, _i: usize, a: &[f32; LANES], c: [f32; 4]) {
        // p <- c alpha + (1 - alpha) p per channel plane (`1 * a` is `a`
        // exactly, so A <- alpha + (1 - alpha) A).
        for (p, ck) in px.into_iter().zip(c) {
            for (pk, &ak) in p.iter_mut().zip(a) {
                *pk = ck * ak + (1.0 - ak) * *pk;
            }
        }
    }
}

/// Per 8 x 8 tile of a band, the pixels whose `A` is still below the
/// threshold.
#[derive(Debug, Clone)]
pub struct OcclusionMap {
    /// Tiles per row, `ceil(w / 8)`.
    tiles_w: usize,
    /// Open pixels per tile, by `ty tiles_w + tx`.
    open: Vec<u8>,
    /// Tiles with an open pixel.
    open_tiles: usize,
}

impl OcclusionMap {
    /// The map of a band `w` pixels wide and `rows` rows high, every pixel
    /// open (`A = 0`).
    pub fn new(w: usize, rows: usize) -> OcclusionMap {
        let tiles_w = w.div_ceil(TILE);
        let tiles_h = rows.div_ceil(TILE);
        let mut open = vec![0u8; tiles_w * tiles_h];
        for ty in 0..tiles_h {
            let th = (rows - ty * TILE).min(TILE);
            for tx in 0..tiles_w {
                let tw = (w - tx * TILE).min(TILE);
                open[ty * tiles_w + tx] = (tw * th) as u8;
            }
        }
        let open_tiles = open.iter().filter(|&&n| n > 0).count();
        OcclusionMap {
            tiles_w,
            open,
            open_tiles,
        }
    }

    /// True when every tile meeting columns `[ia, ib]` and band-local rows
    /// `[ra, rb]` (inclusive, inside the band) has no open pixel.
    #[inline]
    pub fn occluded(&self, ia: usize, ib: usize, ra: usize, rb: usize) -> bool {
        let (tx0, tx1) = (ia / TILE, ib / TILE);
        (ra / TILE..=rb / TILE).all(|ty| {
            self.open[ty * self.tiles_w + tx0..=ty * self.tiles_w + tx1]
                .iter()
                .all(|&n| n == 0)
        })
    }

    /// True when no pixel of the band is open: every later splat is hidden.
    #[inline]
    pub fn all_closed(&self) -> bool {
        self.open_tiles == 0
    }

    /// Pixels still open, over the band.
    pub fn open_pixels(&self) -> u64 {
        self.open.iter().map(|&n| n as u64).sum()
    }
}

/// Front to back, with the occlusion map of threshold `t`.
#[derive(Debug)]
pub struct Under<'a> {
    /// The threshold.
    pub t: f32,
    /// The band's map.
    pub map: &'a mut OcclusionMap,
}

impl Composite for Under<'_> {
    #[inline(always)]
    fn lanes(&mut self, px: Lanes, r: usize, i: usize, a: &[f32; LANES], c: [f32; 4]) {
        let mut crossed = under_lanes(px, a, c, self.t);
        // Each pixel crosses the threshold once: a rare branch.
        while crossed != 0 {
            let l = crossed.trailing_zeros() as usize;
            crossed &= crossed - 1;
            let n = &mut self.map.open[(r / TILE) * self.map.tiles_w + (i + l) / TILE];
            *n -= 1;
            self.map.open_tiles -= (*n == 0) as usize;
        }
    }
}

/// `(C, A) += (c, 1) (1 - A) alpha` on [`LANES`] pixels (`1 * wa` is `wa`
/// exactly, so `A <- A + wa`); returns the bit mask of the lanes whose `A`
/// crossed `t`. The same IEEE operations on every path.
#[inline(always)]
fn under_lanes(px: Lanes, a: &[f32; LANES], c: [f32; 4], t: f32) -> u32 {
    let [pr, pg, pb, pa] = px;
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        let mut crossed = 0u32;
        // SAFETY: SSE is part of x86-64; every load and store is of four
        // floats inside one of the eight-float lane arrays (unaligned forms).
        unsafe {
            let one = _mm_set1_ps(1.0);
            let tv = _mm_set1_ps(t);
            for h in 0..LANES / 4 {
                let o = 4 * h;
                let a0 = _mm_loadu_ps(pa.as_ptr().add(o));
                let wa = _mm_mul_ps(_mm_sub_ps(one, a0), _mm_loadu_ps(a.as_ptr().add(o)));
                let a1 = _mm_add_ps(a0, wa);
                _mm_storeu_ps(pa.as_mut_ptr().add(o), a1);
                for (p, ck) in [&mut *pr, &mut *pg, &mut *pb].into_iter().zip(c) {
                    let q = _mm_loadu_ps(p.as_ptr().add(o));
                    let q = _mm_add_ps(q, _mm_mul_ps(_mm_set1_ps(ck), wa));
                    _mm_storeu_ps(p.as_mut_ptr().add(o), q);
                }
                let m = _mm_and_ps(_mm_cmplt_ps(a0, tv), _mm_cmpge_ps(a1, tv));
                crossed |= (_mm_movemask_ps(m) as u32) << o;
            }
        }
        crossed
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let a0 = *pa;
        let mut wa = [0.0f32; LANES];
        for l in 0..LANES {
            wa[l] = (1.0 - a0[l]) * a[l];
            pa[l] = a0[l] + wa[l];
        }
        for (p, ck) in [pr, pg, pb].into_iter().zip(c) {
            for (pk, &w) in p.iter_mut().zip(&wa) {
                *pk += ck * w;
            }
        }
        let mut crossed = 0u32;
        for l in 0..LANES {
            crossed |= ((a0[l] < t) as u32 & (pa[l] >= t) as u32) << l;
        }
        crossed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Over (back to front) and Under (front to back) composite the same
    /// list to the same pixel, and Under closes a tile exactly when all its
    /// pixels pass the threshold.
    #[test]
    fn over_and_under_agree_and_tiles_close() {
        let layers: Vec<(f32, [f32; 3])> = (0..12)
            .map(|k| (0.05 + 0.07 * k as f32, [0.1 * k as f32 % 1.0, 0.5, 0.9]))
            .collect();
        let (w, rows) = (11usize, 9usize);
        let mut over = BandBuf::new(w, rows);
        let mut under = over.clone();
        let mut map = OcclusionMap::new(w, rows);
        assert_eq!(map.open_pixels(), (w * rows) as u64);
        assert_eq!(map.open, vec![64, 24, 8, 3]);
        // Layers listed back to front; Under takes them reversed.
        for &(a, rgb) in &layers {
            for r in 0..rows {
                Over.run(&mut over, r, 0, &vec![a; w + 8], w, rgb);
            }
        }
        let t = 0.99;
        for &(a, rgb) in layers.iter().rev() {
            for r in 0..rows {
                let mut u = Under { t, map: &mut map };
                u.run(&mut under, r, 0, &vec![a; w + 8], w, rgb);
            }
        }
        for r in 0..rows {
            for i in 0..w {
                let (p, q) = (over.pixel(r, i), under.pixel(r, i));
                for c in 0..4 {
                    assert!((p[c] - q[c]).abs() < 1e-5, "{p:?} vs {q:?}");
                }
            }
        }
        assert!(under.pixel(0, 0)[3] >= t);
        assert_eq!(map.open_pixels(), 0);
        assert!(map.all_closed());
        assert!(map.occluded(0, w - 1, 0, rows - 1));
        // A fresh map: one pixel below the threshold keeps its tile open.
        let mut m = OcclusionMap::new(w, rows);
        let mut band = BandBuf::new(w, rows);
        for r in 0..rows {
            let mut u = Under { t, map: &mut m };
            let mut a = vec![0.995f32; w + 8];
            if r == 3 {
                a[9] = 0.5;
            }
            u.run(&mut band, r, 0, &a, w, [1.0; 3]);
        }
        assert_eq!(m.open_pixels(), 1);
        assert!(!m.all_closed());
        assert!(m.occluded(0, 7, 0, 8));
        assert!(!m.occluded(0, 8, 0, 8));
        assert!(!m.occluded(9, 9, 3, 3));
        assert!(m.occluded(9, 9, 8, 8));
    }
}
