//! The rasterising phase: the image is cut into horizontal bands (rayon
//! tasks, a multiple of the occlusion tile high); every band walks the
//! splat list and composites the rows of the footprints that fall inside it.
//!
//! - ERT off (`t >= 1`): back to front, [`Over`], the list in order;
//! - ERT on: front to back, [`Under`], the list reversed (the reverse of a
//!   back-to-front order is front to back: every voxel before its farther
//!   face neighbours), skipping splats whose rectangle is in closed tiles of
//!   the band's [`OcclusionMap`] or, failing that, whose rectangle's pixels
//!   all have `A >= t` (early splat elimination, error bound in
//!   [`super::composite`]), and stopping when the whole band is closed.

use rayon::prelude::*;

use super::composite::{Composite, OcclusionMap, Over, Under, TILE};
use super::raster::{ceil_i, draw_exact, draw_incremental, floor_i, rows, SplatShape};
use super::table::FootprintTable;

/// How footprints are drawn.
#[derive(Debug, Clone, Copy)]
pub enum Kernel<'a> {
    /// The conic and an exponential per pixel.
    Exact,
    /// Per-row spans, forward differences.
    Incremental,
    /// The orthographic table.
    Table(&'a FootprintTable),
}

impl Kernel<'_> {
    /// Pixels the kernel may draw past the exact rectangle `x ± rx`,
    /// `y ± ry`: the table rounds the centre by up to `1/(2P)` pixel, so 1.
    #[inline(always)]
    pub fn pad(&self) -> i64 {
        matches!(self, Kernel::Table(_)) as i64
    }
}

/// Each splat's rows `[ja, jb]` over the whole image (compact, so that every
/// band scans 8 bytes per splat rather than the whole splat), widened by
/// [`Kernel::pad`].
pub fn spans(splats: &[SplatShape], h: u32, kernel: Kernel) -> Vec<[i32; 2]> {
    let pad = kernel.pad();
    splats
        .par_iter()
        .map(|s| {
            let (ja, jb) = rows(s, 0, h as i64);
            [
                (ja - pad).max(0) as i32,
                (jb + pad).min(h as i64 - 1) as i32,
            ]
        })
        .collect()
}

/// What the bands did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BandCounts {
    /// (splat, band) pieces: a splat is one piece per band its rows meet.
    pub pieces: u64,
    /// Pieces skipped by early splat elimination.
    pub pieces_skipped: u64,
    /// Bands.
    pub bands: u64,
}

/// Rasterises `splats` (back-to-front list; `spans[k]` = rows `[ja, jb]` of
/// splat `k`, from [`spans`]) into a `w x h` premultiplied RGBA buffer, with
/// exponent cut `cut`, footprints by `kernel`, ERT threshold `ert` (`>= 1`:
/// off).
pub fn rasterise(
    splats: &[SplatShape],
    spans: &[[i32; 2]],
    (w, h): (u32, u32),
    cut: f32,
    kernel: Kernel,
    ert: f32,
) -> (Vec<[f32; 4]>, BandCounts) {
    let mut acc = vec![[0.0f32; 4]; w as usize * h as usize];
    // Several bands per thread: the splats crowd in the middle rows.
    let bands = (rayon::current_num_threads() * 4).max(1);
    let rows_per = (h as usize).div_ceil(bands).div_ceil(TILE).max(1) * TILE;
    let counts = acc
        .par_chunks_mut(rows_per * w as usize)
        .enumerate()
        .map(|(b, band)| {
            let j0 = (b * rows_per) as i64;
            let rows = band.len() / w as usize;
            let j1 = j0 + rows as i64;
            let (r0, r1) = (j0 as i32, j1 as i32);
            let mine = splats
                .iter()
                .zip(spans)
                .filter(|(_, r)| r[1] >= r0 && r[0] < r1);
            if ert >= 1.0 {
                let mut n = 0u64;
                for (s, _) in mine {
                    draw(s, band, w, j0, j1, cut, kernel, &mut Over);
                    n += 1;
                }
                return BandCounts {
                    pieces: n,
                    pieces_skipped: 0,
                    bands: 1,
                };
            }
            let mut map = OcclusionMap::new(w as usize, rows);
            let mut c = BandCounts {
                bands: 1,
                ..Default::default()
            };
            for (s, r) in mine.rev() {
                c.pieces += 1;
                if map.all_closed() {
                    c.pieces_skipped += 1;
                    continue;
                }
                // The splat's rectangle, clipped to the band and the image.
                let ra = (r[0].max(r0) - r0) as usize;
                let rb = (r[1].min(r1 - 1) - r0) as usize;
                let pad = kernel.pad();
                let ia = (ceil_i(s.x - s.rx - 0.5) - pad).max(0) as usize;
                let ib = (floor_i(s.x + s.rx - 0.5) + pad).min(w as i64 - 1);
                if ib < ia as i64 {
                    continue;
                }
                let ib = ib as usize;
                // Closed tiles (cheap), else every pixel of the rectangle.
                if map.occluded(ia, ib, ra, rb)
                    || rect_closed(band, w as usize, ia, ib, ra, rb, ert)
                {
                    c.pieces_skipped += 1;
                    continue;
                }
                let mut u = Under {
                    t: ert,
                    map: &mut map,
                };
                draw(s, band, w, j0, j1, cut, kernel, &mut u);
            }
            c
        })
        .reduce(BandCounts::default, |a, b| BandCounts {
            pieces: a.pieces + b.pieces,
            pieces_skipped: a.pieces_skipped + b.pieces_skipped,
            bands: a.bands + b.bands,
        });
    (acc, counts)
}

/// True when every pixel in columns `[ia, ib]` of band-local rows
/// `[ra, rb]` has `A >= t`.
#[inline]
fn rect_closed(
    band: &[[f32; 4]],
    w: usize,
    ia: usize,
    ib: usize,
    ra: usize,
    rb: usize,
    t: f32,
) -> bool {
    (ra..=rb).all(|r| band[r * w + ia..=r * w + ib].iter().all(|p| p[3] >= t))
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn draw<C: Composite>(
    s: &SplatShape,
    band: &mut [[f32; 4]],
    w: u32,
    j0: i64,
    j1: i64,
    cut: f32,
    kernel: Kernel,
    comp: &mut C,
) {
    match kernel {
        Kernel::Table(t) => t.draw(s.x, s.y, s.depth0, s.rgb, band, w, j0, j1, comp),
        Kernel::Incremental => draw_incremental(s, band, w, j0, j1, cut, comp),
        Kernel::Exact => draw_exact(s, band, w, j0, j1, cut, comp),
    }
}
