//! The splatting renderer: classify, order, project, rasterise.
//!
//! 1. **Order** (`order_ms`): the kept voxels back to front in the chosen
//!    [`Order`] (threshold culling: `tau = 0` voxels are never drawn), each
//!    projected to its EWA [`Footprint`](super::footprint::Footprint); the
//!    splats go into one list, in drawing order. With `sparse` (default) the
//!    transparency pre-pass builds line masks of the kept voxels (in
//!    parallel, `prepass_ms`) and the axis/DDA orders walk only those (same
//!    sequence as the full walk, [`order::collect_kept_map`]), in parallel
//!    chunks of slices / planes, projecting each voxel as it is written to
//!    its slot (`project_ms`; off-screen voxels stay as never-drawn holes);
//!    without it, the full walk tests every voxel's threshold and projects
//!    as it goes, on one thread.
//! 2. **Splat** (`splat_ms`): the image is cut into horizontal bands, rayon
//!    tasks ([`bands`]); the splats are binned by band once (`bin_ms`) and
//!    every band walks its own splats and composites their rows that fall
//!    inside it: back to front without ERT
//!    (`C <- c alpha + (1 - alpha) C`, `A <- alpha + (1 - alpha) A`,
//!    premultiplied, the splat in front), or front to back with early splat
//!    elimination (default, threshold `ert`; [`super::composite`]).
//!    Footprints by forward differences along each row's span
//!    ([`draw_incremental`](super::raster::draw_incremental), default), or
//!    the conic and an exponential per pixel
//!    ([`draw_exact`](super::raster::draw_exact)), or (orthographic,
//!    `table_phases > 0`) a [`FootprintTable`] at sub-pixel phases.
//! 3. The background goes behind: `final = C + (1 - A) background`.

use std::time::Instant;

use rayon::prelude::*;

use super::bands::{self, BandCounts, Kernel};
use super::classify::{Class, Classifier};
use super::footprint::FootprintModel;
use super::order::{self, sort::SortScratch, Order, OrderView};
use super::project::{IndexSplit, OrthoCentres};
use super::record::{Conic, ShapeOf, Splat};
use super::table::FootprintTable;
use crate::error::Result;
use crate::image::Image;
use crate::render::VolumeInput;
use crate::scene::camera::{Projection, View};
use crate::scene::TransferFunction;

/// Options of the splatting renderer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplatOptions {
    /// Visit order.
    pub order: Order,
    /// Reconstruction kernel standard deviation, in voxels (default 0.6).
    pub sigma: f64,
    /// Screen-space low-pass variance, pixels² (default 1, as EWA).
    pub low_pass: f64,
    /// Footprint cut, standard deviations (default 3).
    pub k_cut: f64,
    /// Transparency pre-pass and sparse walks, parallel projection
    /// (default); `false`: the full walk testing every voxel, one thread.
    pub sparse: bool,
    /// Sub-pixel phases per pixel of the orthographic footprint table
    /// (default 32; 0: no table). The table rounds centres to `1/P` pixel:
    /// at 32 phases 0.40-0.68/255 max-abs from the exact footprints on
    /// MNI152 256^3 (`bench --splat`, docs/experiments/splatting.md), at
    /// 8 phases up to 1.9/255. Overrides `incremental` for orthographic
    /// views; perspective views never use it.
    pub table_phases: u32,
    /// Footprints by per-row spans and forward differences (default; exact
    /// to f32 rounding, see [`super::raster`]); `false`: the conic and an
    /// exponential per pixel.
    pub incremental: bool,
    /// Early splat elimination threshold in `(0, 1]` (default 0.99, as
    /// `render --ert`): splats are composited front to back and skipped
    /// where every 8 x 8 tile under their rectangle has reached it (error
    /// per channel at most `(1 - ert) M`, [`super::composite`]). `1`: off,
    /// back to front, the exact image of the renderer without it.
    pub ert: f32,
}

impl Default for SplatOptions {
    fn default() -> Self {
        SplatOptions {
            order: Order::Dda,
            sigma: 0.6,
            low_pass: 1.0,
            k_cut: 3.0,
            sparse: true,
            table_phases: 32,
            incremental: true,
            ert: 0.99,
        }
    }
}

/// What one splatting frame did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct SplatStats {
    /// The order used.
    pub order: String,
    /// Voxels in the grid.
    pub voxels_total: u64,
    /// Voxels with zero extinction (never drawn).
    pub voxels_culled_transparent: u64,
    /// Visible voxels behind the eye or whose footprint misses the image.
    pub voxels_offscreen: u64,
    /// Footprints drawn.
    pub voxels_drawn: u64,
    /// `voxels_drawn / voxels_total`, the paper's fill rate.
    pub fill_rate: f64,
    /// Line masks built by the transparency pre-pass (one volume pass each;
    /// 0 without `sparse` or for the sorts' own culling).
    pub mask_passes: u64,
    /// Footprint table phases used (0: exact per-pixel footprints).
    pub table_phases: u32,
    /// Ordering + culling + projection (pre-pass included), ms.
    pub order_ms: f64,
    /// Rasterising and compositing, ms.
    pub splat_ms: f64,
    /// Of `order_ms`: the transparency pre-pass, building the line masks
    /// (sparse path; the full walk orders and projects together, so 0
    /// there).
    pub prepass_ms: f64,
    /// Of `order_ms`: the ordering of the kept voxels with their projection
    /// (sparse path: one parallel pass writes each projected voxel to its
    /// slot; 0 for the full walk).
    pub project_ms: f64,
    /// Of `splat_ms`: binning the splats by band ([`bands::bin`]).
    pub bin_ms: f64,
    /// Of `splat_ms`: the banded rasteriser.
    pub raster_ms: f64,
    /// Early splat elimination threshold (1 = off).
    pub ert_threshold: f64,
    /// Bound on any channel's change by early splat elimination:
    /// `(1 - threshold) max(max TF radiance, max background)` (0 when off).
    pub ert_error_bound: f64,
    /// (splat, band) pieces the bands walked (each splat is one piece per
    /// band its rows meet; bands are `h / (4 threads)` rows, rounded up to 8).
    pub pieces: u64,
    /// Of `pieces`, skipped by early splat elimination.
    pub pieces_skipped_ert: u64,
    /// Bands.
    pub bands: u64,
    /// Image pixels (`width · height`: cleared, and composited over the
    /// background, once each a frame).
    pub pixels: u64,
    /// CPU time of the process (all threads) during the order phase, ms:
    /// on a loaded machine wall times include time spent descheduled.
    pub order_cpu_ms: f64,
    /// CPU time of the process (all threads) during the splat phase, ms.
    pub splat_cpu_ms: f64,
}

/// CPU time of the whole process (all threads), seconds.
pub fn process_cpu_s() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec and the clock id a
    // constant Linux supports.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return f64::NAN;
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// What the order and splat phases of one frame give back.
struct Frame {
    /// Premultiplied RGBA, background not yet added.
    acc: Vec<[f32; 4]>,
    counts: BandCounts,
    visible: u64,
    offscreen: u64,
    mask_passes: u64,
    prepass_ms: f64,
    order_ms: f64,
    bin_ms: f64,
    splat_ms: f64,
    /// Process CPU seconds at the end of the order and splat phases.
    c1: f64,
    c2: f64,
}

/// Orders, projects and rasterises one frame with list records `Splat<S>`
/// (`()`: the orthographic shape is the frame's; `Conic`: each record's);
/// also whether the footprint table was used.
fn frame<S: ShapeOf>(
    input: &VolumeInput,
    view: &View,
    opts: &SplatOptions,
    class: &Classifier,
    model: &FootprintModel,
    order_view: &OrderView,
    t0: Instant,
) -> (Frame, bool) {
    let vol = &*input.volume;
    let (w, h) = (view.width, view.height);
    let dims = vol.dims;
    let (wf, hf) = (w as f32, h as f32);
    let split = IndexSplit::new(dims);
    // Orthographic: every footprint has one shape, and its centre is
    // affine in the index.
    let ortho = OrthoCentres::new(view, vol).zip(model.orthographic_shape());
    let shared = ortho.map(|(_, f)| Conic::of(&f)).unwrap_or_default();
    // The splat of kept voxel `idx` of class `c`, or None when off screen.
    let splat_of = |idx: u64, c: Class| -> Option<Splat<S>> {
        let g = split.split(idx);
        let f = match ortho {
            Some((oc, mut f)) => {
                [f.x, f.y] = oc.centre(g);
                f
            }
            None => model.project(vol.grid_to_world(g.map(|v| v as f64)))?,
        };
        if f.x + f.rx < 0.0 || f.x - f.rx > wf || f.y + f.ry < 0.0 || f.y - f.ry > hf {
            return None;
        }
        Some(Splat::new(&f, c.tau * f.l0, c.rgb))
    };
    let mut mask_passes = 0u64;
    let mut prepass_ms = 0.0;
    let (splats, visible, offscreen) = if opts.sparse {
        let kept = |idx: u64| {
            let c = class.get(idx);
            (c.tau > 0.0).then_some(c)
        };
        let visible = |idx: u64| class.visible(idx);
        // Projection as the ordering writes each voxel (in parallel);
        // off-screen voxels stay in the list as holes, never drawn.
        let emit = |i: u64, c: Class| splat_of(i, c).unwrap_or(Splat::hole());
        let mut splats = Vec::new();
        let k = order::collect_kept_map(
            opts.order,
            dims,
            order_view,
            &visible,
            &kept,
            &emit,
            &mut SortScratch::default(),
            &mut splats,
        );
        mask_passes = k.masks as u64;
        prepass_ms = k.prepass_ms;
        let holes = splats.par_iter().filter(|s| s.is_hole()).count() as u64;
        let n = splats.len() as u64;
        (splats, n, holes)
    } else {
        let mut splats = Vec::new();
        let mut visible = 0u64;
        order::visit_with(
            opts.order,
            dims,
            order_view,
            |idx| class.visible(idx),
            &mut SortScratch::default(),
            |idx| {
                visible += 1;
                splats.extend(splat_of(idx, class.get(idx)));
            },
        );
        let offscreen = visible - splats.len() as u64;
        (splats, visible, offscreen)
    };
    let order_ms = t0.elapsed().as_secs_f64() * 1e3;
    crate::base::cancel::checkpoint();

    let t1 = Instant::now();
    let c1 = process_cpu_s();
    let cut = model.exponent_cut();
    let table = match model.orthographic_shape() {
        Some(f) if opts.table_phases > 0 => Some(FootprintTable::new(&f, cut, opts.table_phases)),
        _ => None,
    };
    let kernel = match &table {
        Some(t) => Kernel::Table(t),
        None if opts.incremental => Kernel::Incremental,
        None => Kernel::Exact,
    };
    let bins = bands::bin(&splats, &shared, h, kernel);
    let bin_ms = t1.elapsed().as_secs_f64() * 1e3;
    crate::base::cancel::checkpoint();
    let (acc, counts) = bands::rasterise(&splats, &shared, &bins, (w, h), cut, kernel, opts.ert);
    drop(bins);
    drop(splats);
    let splat_ms = t1.elapsed().as_secs_f64() * 1e3;
    let c2 = process_cpu_s();
    let frame = Frame {
        acc,
        counts,
        visible,
        offscreen,
        mask_passes,
        prepass_ms,
        order_ms,
        bin_ms,
        splat_ms,
        c1,
        c2,
    };
    (frame, table.is_some())
}

/// [`SplatStats::ert_error_bound`]: `(1 - ert) max(max radiance, max
/// background)` for `ert < 1`, else 0 (derivation in [`super::composite`]).
pub fn ert_bound(ert: f32, tf: &TransferFunction, background: [f64; 3]) -> f64 {
    if ert < 1.0 {
        let m = background.iter().fold(tf.max_radiance(), |a, &b| a.max(b));
        (1.0 - ert as f64) * m
    } else {
        0.0
    }
}

/// Renders `input` by EWA splatting in `opts.order`.
pub fn render_splat(input: &VolumeInput, opts: &SplatOptions) -> Result<(Image, SplatStats)> {
    let scene = &input.scene;
    let vol = &*input.volume;
    let view = scene.view();
    let (w, h) = (view.width, view.height);
    let t0 = Instant::now();
    let c0 = process_cpu_s();
    let class = Classifier::new(vol, &scene.transfer, input.range);
    let model = FootprintModel::new(&view, vol.spacing, opts.sigma, opts.low_pass, opts.k_cut);
    let order_view = match view.projection {
        Projection::Orthographic { .. } => OrderView::orthographic(view.forward, vol.spacing),
        Projection::Perspective { .. } => OrderView::Perspective {
            eye: vol.world_to_grid(view.eye),
            spacing: vol.spacing,
        },
    };
    let (frame, table_used) = match view.projection {
        Projection::Orthographic { .. } => {
            frame::<()>(input, &view, opts, &class, &model, &order_view, t0)
        }
        Projection::Perspective { .. } => {
            frame::<Conic>(input, &view, opts, &class, &model, &order_view, t0)
        }
    };
    let f = &frame;
    let project_ms = if opts.sparse {
        f.order_ms - f.prepass_ms
    } else {
        0.0
    };
    let dims = vol.dims;

    let bg = scene.image.background.map(|c| c as f32);
    let mut img = Image::new(w, h);
    for (px, a) in img.pixels.iter_mut().zip(&f.acc) {
        let t = 1.0 - a[3];
        *px = [a[0] + t * bg[0], a[1] + t * bg[1], a[2] + t * bg[2], a[3]];
    }
    let total: u64 = dims.iter().product();
    let drawn = f.visible - f.offscreen;
    let stats = SplatStats {
        order: opts.order.name().into(),
        voxels_total: total,
        voxels_culled_transparent: total - f.visible,
        voxels_offscreen: f.offscreen,
        voxels_drawn: drawn,
        fill_rate: drawn as f64 / total as f64,
        mask_passes: f.mask_passes,
        table_phases: if table_used { opts.table_phases } else { 0 },
        order_ms: f.order_ms,
        splat_ms: f.splat_ms,
        prepass_ms: f.prepass_ms,
        project_ms,
        bin_ms: f.bin_ms,
        raster_ms: f.splat_ms - f.bin_ms,
        ert_threshold: opts.ert.min(1.0) as f64,
        ert_error_bound: ert_bound(opts.ert, &scene.transfer, scene.image.background),
        pieces: f.counts.pieces,
        pieces_skipped_ert: f.counts.pieces_skipped,
        bands: f.counts.bands,
        pixels: w as u64 * h as u64,
        order_cpu_ms: (f.c1 - c0) * 1e3,
        splat_cpu_ms: (f.c2 - f.c1) * 1e3,
    };
    Ok((img, stats))
}
