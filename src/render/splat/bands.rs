//! The rasterising phase: the image is cut into horizontal bands (rayon
//! tasks, a multiple of the occlusion tile high); the splats are binned
//! once per band ([`bin`]: a parallel stable bucket scatter of splat
//! indices, so each band reads only its own splats, in list order), and
//! every band composites the rows of its splats that fall inside it.
//!
//! - ERT off (`t >= 1`): back to front, [`Over`], the list in order;
//! - ERT on: front to back, [`Under`], the list reversed (the reverse of a
//!   back-to-front order is front to back: every voxel before its farther
//!   face neighbours), skipping splats whose rectangle is in closed tiles of
//!   the band's [`OcclusionMap`] or, failing that, whose rectangle's pixels
//!   all have `A >= t` (early splat elimination, error bound in
//!   [`super::composite`]), and stopping when the whole band is closed.
//!
//! On x86-64 CPUs with AVX2 the band loop is compiled a second time for
//! AVX2 and chosen at run time (8-lane exponentials in the kernels; the
//! same IEEE operations in the same order, no fused multiply-adds, so the
//! image is bit-identical to the SSE2 build's).

use rayon::prelude::*;

use super::buffer::BandBuf;
use super::composite::{Composite, OcclusionMap, Over, Under, TILE};
use super::order::scatter::{scatter, Enumerate};
use super::raster::{centres_within, draw_exact, draw_incremental};
use super::record::{Conic, ShapeOf, Splat};
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

/// Rows `[ja, jb]` of splat `s` (shape `c`) in a `h`-row image: pixel
/// centres `j + 1/2` within `ry` of the centre, widened by `pad` (empty,
/// `ja > jb`, for a hole or a splat off the image).
#[inline(always)]
fn row_span<S>(s: &Splat<S>, c: &Conic, h: i64, pad: i64) -> (i64, i64) {
    if s.is_hole() {
        return (0, -1);
    }
    let (ja, jb) = centres_within(s.y, c.ry);
    ((ja - pad).max(0), (jb + pad).min(h - 1))
}

/// The splats of each band, in list order.
#[derive(Debug, Clone)]
pub struct Bins {
    /// Rows per band (a multiple of [`TILE`]).
    pub rows_per: usize,
    /// Bands.
    pub bands: usize,
    /// Splat indices, band by band.
    pub idx: Vec<u32>,
    /// Band `b`'s indices are `idx[starts[b] .. starts[b + 1]]`.
    pub starts: Vec<usize>,
}

/// Splats listed chunk by chunk, once per band their rows meet.
struct BandPieces<'a, S> {
    splats: &'a [Splat<S>],
    shared: &'a Conic,
    chunks: usize,
    h: i64,
    pad: i64,
    rows_per: i64,
}

impl<S: ShapeOf> Enumerate<u32> for BandPieces<'_, S> {
    #[inline]
    fn each(&self, c: usize, mut f: impl FnMut(usize, u32)) {
        let n = self.splats.len();
        let (lo, hi) = (n * c / self.chunks, n * (c + 1) / self.chunks);
        for (k, s) in self.splats[lo..hi].iter().enumerate() {
            let (ja, jb) = row_span(s, s.shape.conic(self.shared), self.h, self.pad);
            if ja > jb {
                continue;
            }
            for b in ja / self.rows_per..=jb / self.rows_per {
                f(b as usize, (lo + k) as u32);
            }
        }
    }
}

/// Bins `splats` (one list, drawing order; shapes their own or `shared`)
/// into the bands of an `h`-row image for `kernel` (rows widened by
/// [`Kernel::pad`]): several bands per thread (the splats crowd in the
/// middle rows), each a multiple of the occlusion tile high.
pub fn bin<S: ShapeOf>(splats: &[Splat<S>], shared: &Conic, h: u32, kernel: Kernel) -> Bins {
    assert!(
        splats.len() < u32::MAX as usize,
        "more than 2^32 - 1 splats in one frame"
    );
    let bands = (rayon::current_num_threads() * 4).max(1);
    let rows_per = (h as usize).div_ceil(bands).div_ceil(TILE).max(1) * TILE;
    let bands = (h as usize).div_ceil(rows_per).max(1);
    let pieces = BandPieces {
        splats,
        shared,
        chunks: (rayon::current_num_threads() * 4).clamp(1, splats.len().max(1)),
        h: h as i64,
        pad: kernel.pad(),
        rows_per: rows_per as i64,
    };
    let mut idx = Vec::new();
    let starts = scatter(&pieces, pieces.chunks, bands, &|k| k, &mut idx);
    Bins {
        rows_per,
        bands,
        idx,
        starts,
    }
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

/// Rasterises `splats` (back-to-front list, binned by [`bin`]) into a
/// `w x h` premultiplied RGBA buffer, with exponent cut `cut`, footprints
/// by `kernel` (shapes the splats' own or `shared`), ERT threshold `ert`
/// (`>= 1`: off).
#[allow(clippy::too_many_arguments)]
pub fn rasterise<S: ShapeOf>(
    splats: &[Splat<S>],
    shared: &Conic,
    bins: &Bins,
    (w, h): (u32, u32),
    cut: f32,
    kernel: Kernel,
    ert: f32,
) -> (Vec<[f32; 4]>, BandCounts) {
    let mut acc = vec![[0.0f32; 4]; w as usize * h as usize];
    #[cfg(target_arch = "x86_64")]
    let avx2 = std::is_x86_feature_detected!("avx2");
    let counts = acc
        .par_chunks_mut(bins.rows_per * w as usize)
        .enumerate()
        .map(|(b, band)| {
            crate::base::cancel::checkpoint();
            let list = &bins.idx[bins.starts[b]..bins.starts[b + 1]];
            let j0 = (b * bins.rows_per) as i64;
            let job = BandJob {
                splats,
                shared,
                list,
                w,
                h: h as i64,
                j0,
                cut,
                kernel,
                ert,
            };
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                // SAFETY: the CPU has AVX2 (checked above).
                return unsafe { band_avx2(&job, band) };
            }
            band_pass(&job, band)
        })
        .reduce(BandCounts::default, |a, b| BandCounts {
            pieces: a.pieces + b.pieces,
            pieces_skipped: a.pieces_skipped + b.pieces_skipped,
            bands: a.bands + b.bands,
        });
    (acc, counts)
}

/// One band's work.
struct BandJob<'a, S> {
    splats: &'a [Splat<S>],
    /// The frame's shape (orthographic records have none).
    shared: &'a Conic,
    /// The band's splats, in list order.
    list: &'a [u32],
    w: u32,
    h: i64,
    /// First row of the band.
    j0: i64,
    cut: f32,
    kernel: Kernel<'a>,
    ert: f32,
}

/// [`band_pass`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn band_avx2<S: ShapeOf>(job: &BandJob<S>, band: &mut [[f32; 4]]) -> BandCounts {
    band_pass(job, band)
}

/// Composites the band's splats into `out` (its rows of the image, module
/// doc) through a channel-plane buffer ([`BandBuf`]).
#[inline(always)]
fn band_pass<S: ShapeOf>(job: &BandJob<S>, out: &mut [[f32; 4]]) -> BandCounts {
    let mut buf = BandBuf::new(job.w as usize, out.len() / job.w as usize);
    let c = band_splats(job, &mut buf);
    buf.write_rgba(out);
    c
}

/// Composites the band's splats into `band`.
#[inline(always)]
fn band_splats<S: ShapeOf>(job: &BandJob<S>, band: &mut BandBuf) -> BandCounts {
    let BandJob {
        splats,
        shared,
        list,
        w,
        h,
        j0,
        cut,
        kernel,
        ert,
    } = *job;
    let rows = band.rows();
    let j1 = j0 + rows as i64;
    let mut c = BandCounts {
        pieces: list.len() as u64,
        pieces_skipped: 0,
        bands: 1,
    };
    // Alphas of one footprint (the table path).
    let mut scratch = match kernel {
        Kernel::Table(t) => t.scratch(),
        _ => Vec::new(),
    };
    // The table's rows of the splat drawn next, fetched while this one is
    // drawn.
    let prefetch = |k: Option<&u32>| {
        if let (Kernel::Table(t), Some(&k)) = (kernel, k) {
            let s = &splats[k as usize];
            t.prefetch(s.x, s.y);
        }
    };
    if ert >= 1.0 {
        for (n, &k) in list.iter().enumerate() {
            prefetch(list.get(n + 1));
            if let Some(&m) = list.get(n + SPLAT_AHEAD) {
                prefetch_record(&splats[m as usize]);
            }
            draw(
                &splats[k as usize],
                shared,
                band,
                j0,
                cut,
                kernel,
                &mut scratch,
                &mut Over,
            );
        }
        return c;
    }
    let mut map = OcclusionMap::new(w as usize, rows);
    let pad = kernel.pad();
    for (n, &k) in list.iter().rev().enumerate() {
        if map.all_closed() {
            c.pieces_skipped += (list.len() - n) as u64;
            break;
        }
        // Front to back: the next splat is the one before in the list.
        prefetch((list.len() - n).checked_sub(2).map(|m| &list[m]));
        if let Some(m) = (list.len() - n).checked_sub(1 + SPLAT_AHEAD) {
            prefetch_record(&splats[list[m] as usize]);
        }
        let s = &splats[k as usize];
        let sc = s.shape.conic(shared);
        // The splat's rectangle, clipped to the band and the image.
        let (ja, jb) = row_span(s, sc, h, pad);
        let ra = (ja.max(j0) - j0) as usize;
        let rb = (jb.min(j1 - 1) - j0) as usize;
        let (ia, ib) = centres_within(s.x, sc.rx);
        let ia = (ia - pad).max(0) as usize;
        let ib = (ib + pad).min(w as i64 - 1);
        if ib < ia as i64 {
            continue;
        }
        let ib = ib as usize;
        // Closed tiles (cheap), else every pixel of the rectangle.
        if map.occluded(ia, ib, ra, rb) || rect_closed(band, ia, ib, ra, rb, ert) {
            c.pieces_skipped += 1;
            continue;
        }
        let mut u = Under {
            t: ert,
            map: &mut map,
        };
        draw(s, shared, band, j0, cut, kernel, &mut scratch, &mut u);
    }
    c
}

/// Splats ahead of the one drawn whose record is fetched into the cache
/// (a band reads its splats from the whole list, skipping the other
/// bands' ones, so the hardware prefetcher does not follow).
const SPLAT_AHEAD: usize = 8;

/// Asks the CPU to fetch one splat record (a hint; no effect on the image).
#[inline(always)]
fn prefetch_record<S>(s: &Splat<S>) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: a prefetch of a live reference's memory (never faults).
        unsafe { _mm_prefetch::<_MM_HINT_T0>(s as *const Splat<S> as *const i8) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = s;
}

/// True when every pixel in columns `[ia, ib]` of band-local rows
/// `[ra, rb]` has `A >= t`.
#[inline(always)]
fn rect_closed(band: &BandBuf, ia: usize, ib: usize, ra: usize, rb: usize, t: f32) -> bool {
    (ra..=rb).all(|r| band.alpha_row(r)[ia..=ib].iter().all(|&a| a >= t))
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn draw<C: Composite, S: ShapeOf>(
    s: &Splat<S>,
    shared: &Conic,
    band: &mut BandBuf,
    j0: i64,
    cut: f32,
    kernel: Kernel,
    scratch: &mut [f32],
    comp: &mut C,
) {
    match kernel {
        Kernel::Table(t) => t.draw(s.x, s.y, s.depth0, s.rgb, band, j0, scratch, comp),
        Kernel::Incremental => draw_incremental(&s.full(shared), band, j0, cut, comp),
        Kernel::Exact => draw_exact(&s.full(shared), band, j0, cut, comp),
    }
}
