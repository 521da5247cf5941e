//! The splatting renderer: classify, order, project, rasterise.
//!
//! 1. **Order** (`order_ms`): the kept voxels back to front in the chosen
//!    [`Order`] (threshold culling: `tau = 0` voxels are never drawn), each
//!    projected to its EWA [`Footprint`](super::footprint::Footprint); the
//!    splats go into one list, in drawing order. With `sparse` (default) the
//!    transparency pre-pass builds line masks of the kept voxels and the
//!    axis/DDA orders walk only those (same sequence as the full walk,
//!    [`order::collect_kept`]), and the projection runs in parallel over the
//!    ordered list (rayon's ordered collect); without it, the full walk
//!    tests every voxel's threshold and projects as it goes, on one thread.
//! 2. **Splat** (`splat_ms`): the image is cut into horizontal bands, rayon
//!    tasks; every band walks the whole list in order and composites the
//!    footprints' rows that fall inside it, back to front:
//!    `C <- c alpha + (1 - alpha) C`, `A <- alpha + (1 - alpha) A`
//!    (premultiplied; the splat is in front of what is already there).
//!    Footprints by forward differences along each row's span
//!    ([`draw_incremental`], default), or the conic and an exponential per
//!    pixel ([`draw_exact`]), or (orthographic, `table_phases > 0`) a
//!    [`FootprintTable`] at sub-pixel phases.
//! 3. The background goes behind: `final = C + (1 - A) background`.

use std::time::Instant;

use rayon::prelude::*;

use super::classify::{Class, Classifier};
use super::footprint::FootprintModel;
use super::order::{self, sort::SortScratch, Order, OrderView};
use super::raster::{draw_exact, draw_incremental, rows, SplatShape};
use super::table::FootprintTable;
use crate::error::Result;
use crate::image::Image;
use crate::render::VolumeInput;
use crate::scene::camera::Projection;

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
    /// (0, the default: no table). The table rounds centres to `1/P` pixel
    /// (measured: `bench --splat`); it overrides `incremental`.
    pub table_phases: u32,
    /// Footprints by per-row spans and forward differences (default; exact
    /// to f32 rounding, see [`super::raster`]); `false`: the conic and an
    /// exponential per pixel.
    pub incremental: bool,
}

impl Default for SplatOptions {
    fn default() -> Self {
        SplatOptions {
            order: Order::Dda,
            sigma: 0.6,
            low_pass: 1.0,
            k_cut: 3.0,
            sparse: true,
            table_phases: 0,
            incremental: true,
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

type Splat = SplatShape;

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
    let dims = vol.dims;
    let (wf, hf) = (w as f32, h as f32);
    // The splat of kept voxel `idx` of class `c`, or None when off screen.
    let splat_of = |idx: u64, c: Class| -> Option<Splat> {
        let i = idx % dims[0];
        let jk = idx / dims[0];
        let g = [i as f64, (jk % dims[1]) as f64, (jk / dims[1]) as f64];
        let f = model.project(vol.grid_to_world(g))?;
        if f.x + f.rx < 0.0 || f.x - f.rx > wf || f.y + f.ry < 0.0 || f.y - f.ry > hf {
            return None;
        }
        Some(Splat {
            x: f.x,
            y: f.y,
            q: f.q,
            depth0: c.tau * f.l0,
            rgb: c.rgb,
            rx: f.rx,
            ry: f.ry,
        })
    };
    let mut mask_passes = 0u64;
    let (splats, visible) = if opts.sparse {
        let kept = |idx: u64| {
            let c = class.get(idx);
            (c.tau > 0.0).then_some(c)
        };
        let mut idxs = Vec::new();
        let visible = |idx: u64| class.visible(idx);
        mask_passes = order::collect_kept(
            opts.order,
            dims,
            &order_view,
            &visible,
            &kept,
            &mut SortScratch::default(),
            &mut idxs,
        ) as u64;
        let splats: Vec<Splat> = idxs
            .par_iter()
            .filter_map(|&(i, c)| splat_of(i, c))
            .collect();
        (splats, idxs.len() as u64)
    } else {
        let mut splats = Vec::new();
        let mut visible = 0u64;
        order::visit_with(
            opts.order,
            dims,
            &order_view,
            |idx| class.visible(idx),
            &mut SortScratch::default(),
            |idx| {
                visible += 1;
                splats.extend(splat_of(idx, class.get(idx)));
            },
        );
        (splats, visible)
    };
    let offscreen = visible - splats.len() as u64;
    let order_ms = t0.elapsed().as_secs_f64() * 1e3;

    let t1 = Instant::now();
    let c1 = process_cpu_s();
    let cut = model.exponent_cut();
    let table = match model.orthographic_shape() {
        Some(f) if opts.table_phases > 0 => Some(FootprintTable::new(&f, cut, opts.table_phases)),
        _ => None,
    };
    // Each splat's rows [ja, jb] (compact, so that every band scans 8
    // bytes per splat rather than the whole splat).
    let spans: Vec<[i32; 2]> = splats
        .par_iter()
        .map(|s| {
            let (ja, jb) = rows(s, 0, h as i64);
            [ja as i32, jb as i32]
        })
        .collect();
    let mut acc = vec![[0.0f32; 4]; w as usize * h as usize];
    // Several bands per thread: the splats crowd in the middle rows.
    let bands = (rayon::current_num_threads() * 4).max(1);
    let rows_per = (h as usize).div_ceil(bands).max(1);
    acc.par_chunks_mut(rows_per * w as usize)
        .enumerate()
        .for_each(|(b, band)| {
            let j0 = (b * rows_per) as i64;
            let j1 = j0 + (band.len() / w as usize) as i64;
            let (r0, r1) = (j0 as i32, j1 as i32);
            let mine = splats
                .iter()
                .zip(&spans)
                .filter(|(_, r)| r[1] >= r0 && r[0] < r1)
                .map(|(s, _)| s);
            match &table {
                Some(t) => mine.for_each(|s| t.draw(s.x, s.y, s.depth0, s.rgb, band, w, j0, j1)),
                None if opts.incremental => {
                    mine.for_each(|s| draw_incremental(s, band, w, j0, j1, cut))
                }
                None => mine.for_each(|s| draw_exact(s, band, w, j0, j1, cut)),
            }
        });
    let splat_ms = t1.elapsed().as_secs_f64() * 1e3;
    let c2 = process_cpu_s();

    let bg = scene.image.background.map(|c| c as f32);
    let mut img = Image::new(w, h);
    for (px, a) in img.pixels.iter_mut().zip(&acc) {
        let t = 1.0 - a[3];
        *px = [a[0] + t * bg[0], a[1] + t * bg[1], a[2] + t * bg[2], a[3]];
    }
    let total: u64 = dims.iter().product();
    let drawn = splats.len() as u64;
    let stats = SplatStats {
        order: opts.order.name().into(),
        voxels_total: total,
        voxels_culled_transparent: total - visible,
        voxels_offscreen: offscreen,
        voxels_drawn: drawn,
        fill_rate: drawn as f64 / total as f64,
        mask_passes,
        table_phases: if table.is_some() {
            opts.table_phases
        } else {
            0
        },
        order_ms,
        splat_ms,
        order_cpu_ms: (c1 - c0) * 1e3,
        splat_cpu_ms: (c2 - c1) * 1e3,
    };
    Ok((img, stats))
}
