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

/// Tile side of the occlusion map, pixels.
pub const TILE: usize = 8;

/// How a splat's alphas enter the band.
pub trait Composite {
    /// Composites `alpha` (one per pixel) of colour `rgb` into `pix`, the
    /// pixels `i0 ..` of band-local row `r`.
    fn run(&mut self, pix: &mut [[f32; 4]], r: usize, i0: usize, alpha: &[f32], rgb: [f32; 3]);
}

/// Back to front: the splat in front of the pixel.
#[derive(Debug, Clone, Copy, Default)]
pub struct Over;

impl Composite for Over {
    #[inline(always)]
    fn run(&mut self, pix: &mut [[f32; 4]], _r: usize, _i0: usize, alpha: &[f32], rgb: [f32; 3]) {
        // (c, 1) alpha + (1 - alpha) p on the four channels at once
        // (`1 * a` is `a` exactly).
        let c = [rgb[0], rgb[1], rgb[2], 1.0];
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE is part of x86-64; loads and stores are of the
            // 16-byte pixels of `pix` (unaligned forms).
            unsafe {
                let cv = _mm_loadu_ps(c.as_ptr());
                let one = _mm_set1_ps(1.0);
                for (p, &a) in pix.iter_mut().zip(alpha) {
                    let av = _mm_set1_ps(a);
                    let t = _mm_sub_ps(one, av);
                    let pv = _mm_loadu_ps(p.as_ptr());
                    let r = _mm_add_ps(_mm_mul_ps(cv, av), _mm_mul_ps(t, pv));
                    _mm_storeu_ps(p.as_mut_ptr(), r);
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        for (p, &a) in pix.iter_mut().zip(alpha) {
            let t = 1.0 - a;
            for (pk, ck) in p.iter_mut().zip(c) {
                *pk = ck * a + t * *pk;
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
    fn run(&mut self, pix: &mut [[f32; 4]], r: usize, i0: usize, alpha: &[f32], rgb: [f32; 3]) {
        let t = self.t;
        let row0 = (r / TILE) * self.map.tiles_w;
        // (C, A) += (c, 1) (1 - A) alpha on the four channels at once
        // (`1 * wa` is `wa` exactly, so `A` is `A + wa` as before).
        let c = [rgb[0], rgb[1], rgb[2], 1.0];
        for (k, (p, &a)) in pix.iter_mut().zip(alpha).enumerate() {
            let (a0, a1) = under_pixel(p, a, c);
            // Each pixel crosses the threshold once: a rare branch.
            if a0 < t && a1 >= t {
                let n = &mut self.map.open[row0 + (i0 + k) / TILE];
                *n -= 1;
                self.map.open_tiles -= (*n == 0) as usize;
            }
        }
    }
}

/// `p += c (1 - A) a` on the four channels of one premultiplied pixel
/// (`c[3] = 1`); returns `A` before and after. The same IEEE operations
/// in the same order on every path (no fused multiply-add).
#[inline(always)]
fn under_pixel(p: &mut [f32; 4], a: f32, c: [f32; 4]) -> (f32, f32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE is part of x86-64; the load and store are of the 16
        // bytes of `p` (unaligned forms).
        unsafe {
            let pv = _mm_loadu_ps(p.as_ptr());
            let a0 = _mm_shuffle_ps::<0xff>(pv, pv);
            let wa = _mm_mul_ps(_mm_sub_ps(_mm_set1_ps(1.0), a0), _mm_set1_ps(a));
            let r = _mm_add_ps(pv, _mm_mul_ps(_mm_loadu_ps(c.as_ptr()), wa));
            _mm_storeu_ps(p.as_mut_ptr(), r);
            (
                _mm_cvtss_f32(a0),
                _mm_cvtss_f32(_mm_shuffle_ps::<0xff>(r, r)),
            )
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let a0 = p[3];
        let wa = (1.0 - a0) * a;
        for (pk, ck) in p.iter_mut().zip(c) {
            *pk += ck * wa;
        }
        (a0, p[3])
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
        let mut over = vec![[0.0f32; 4]; w * rows];
        let mut under = over.clone();
        let mut map = OcclusionMap::new(w, rows);
        assert_eq!(map.open_pixels(), (w * rows) as u64);
        assert_eq!(map.open, vec![64, 24, 8, 3]);
        // Layers listed back to front; Under takes them reversed.
        for &(a, rgb) in &layers {
            for r in 0..rows {
                Over.run(&mut over[r * w..][..w], r, 0, &vec![a; w], rgb);
            }
        }
        let t = 0.99;
        for &(a, rgb) in layers.iter().rev() {
            for r in 0..rows {
                let mut u = Under { t, map: &mut map };
                u.run(&mut under[r * w..][..w], r, 0, &vec![a; w], rgb);
            }
        }
        for (p, q) in over.iter().zip(&under) {
            for c in 0..4 {
                assert!((p[c] - q[c]).abs() < 1e-5, "{p:?} vs {q:?}");
            }
        }
        assert!(under[0][3] >= t);
        assert_eq!(map.open_pixels(), 0);
        assert!(map.all_closed());
        assert!(map.occluded(0, w - 1, 0, rows - 1));
        // A fresh map: one pixel below the threshold keeps its tile open.
        let mut m = OcclusionMap::new(w, rows);
        let mut band = vec![[0.0f32; 4]; w * rows];
        for r in 0..rows {
            let mut u = Under { t, map: &mut m };
            let mut a = vec![0.995f32; w];
            if r == 3 {
                a[9] = 0.5;
            }
            u.run(&mut band[r * w..][..w], r, 0, &a, [1.0; 3]);
        }
        assert_eq!(m.open_pixels(), 1);
        assert!(!m.all_closed());
        assert!(m.occluded(0, 7, 0, 8));
        assert!(!m.occluded(0, 8, 0, 8));
        assert!(!m.occluded(9, 9, 3, 3));
        assert!(m.occluded(9, 9, 8, 8));
    }
}
