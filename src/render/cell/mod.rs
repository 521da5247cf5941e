//! Cell projection with ray-segment lists and partial composition — the
//! renderer of the paper's section 2.1, on one machine.
//!
//! A frame has three phases:
//!
//! 1. **Projection** ([`project`], [`bin`]): every vertex is transformed once;
//!    cells whose scalar range is fully transparent, or that miss the image,
//!    are culled; the rest are binned into fixed screen tiles.
//! 2. **Scan conversion** ([`setup`], [`scan`], [`integrate`], [`list`]): per
//!    tile, in stored cell order, each cell's covered pixel centres get one ray
//!    segment each (entry/exit depth, scalar at both, integrated colour and
//!    alpha), inserted into the pixel's depth-sorted list with partial
//!    composition.
//! 3. **Composition**: each list is composited front to back over the background.
//!
//! Tiles are independent, so rayon renders them in parallel; each pixel sees
//! the same segments in the same order whatever the thread count or tile
//! size, so the image is bit-for-bit the same with `--threads 1`.

// Comparisons are written `!(a < b)` on purpose throughout: NaN then takes
// the safe branch (not covered, not inside).
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bin;
pub mod cull;
pub mod ert;
pub mod fastmath;
pub mod floor;
pub mod grid;
pub mod integrate;
pub mod list;
pub mod order;
pub mod project;
pub mod radix;
pub mod record;
pub mod scan;
pub mod scan_box;
pub mod setup;
pub mod single;
pub mod single_x8;
pub mod sizes;
pub mod target;
pub mod watch;

use std::time::Instant;

use rayon::prelude::*;

pub use ert::{ErtOptions, ErtSpan, ErtStructure};
pub use integrate::{Integrator, PreparedTf};
pub use list::SegmentLists;
pub use order::CellOrder;

use crate::image::Image;
use crate::render::RenderInput;
pub use scan::{Pending, ScanCounts, ScanTarget};

/// Options of the cell-projection renderer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellOptions {
    /// Segment integrator.
    pub integrator: Integrator,
    /// Merge touching segments on insertion (the paper's partial composition).
    pub partial_composition: bool,
    /// Edge of the square screen tiles, pixels. Does not change the image
    /// without ERT; with ERT it is rounded to whole entries
    /// ([`ErtOptions::tile_dims`]) and the image may depend on it.
    pub tile_size: u32,
    /// Order of scan conversion.
    pub cell_order: CellOrder,
    /// Early ray termination.
    pub ert: ErtOptions,
    /// Also run the oracle pass ([`ert::oracle`]) and report it in the stats.
    pub oracle: bool,
    /// Merge touching segments in a canonical order ([`canonical`]) so the
    /// image does not depend on how cells are distributed (over tiles, or over
    /// the nodes of a cluster): bit for bit the cluster's image without ERT.
    /// Costs list memory (a run of joined segments is kept as `O(log k)`
    /// pieces until the final composite). Off by default.
    pub canonical: bool,
}

impl Default for CellOptions {
    fn default() -> Self {
        CellOptions {
            integrator: Integrator::Exact,
            partial_composition: true,
            tile_size: 32,
            cell_order: CellOrder::FrontToBack,
            ert: ErtOptions::DEFAULT,
            oracle: false,
            canonical: false,
        }
    }
}

/// What a cell-projection render did, and how long each phase took.
/// Key names are a contract for scripts (see the README).
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct CellStats {
    /// Cells in the mesh.
    pub cells_total: u64,
    /// Cells skipped: their scalar interval has zero opacity.
    pub cells_culled_empty: u64,
    /// Cells skipped: outside the image or behind the eye.
    pub cells_culled_offscreen: u64,
    /// Cells projected (total minus both culls).
    pub cells_projected: u64,
    /// Projected cells whose bounding box holds no pixel centre.
    pub cells_no_pixel_centre: u64,
    /// Cells that cover no ray stretch of positive length (zero volume in f32).
    pub cells_degenerate: u64,
    /// (cell, tile) pairs scanned; over `cells_projected`, the tiling overhead.
    pub cell_tile_pairs: u64,
    /// Pixel centres found inside a cell: in orthographic views the covered
    /// ones (the scalar span scan and the vectorised box scan test
    /// different candidate sets but count alike, so the virtual clock does
    /// not depend on the CPU), in perspective every one tested.
    pub pixels_tested: u64,
    /// Ray segments produced by scan conversion.
    pub segments_generated: u64,
    /// Merge operations done by partial composition.
    pub segments_merged: u64,
    /// Segments left in the lists at the end.
    pub segments_stored: u64,
    /// Pixels with a non-empty list.
    pub pixels_covered: u64,
    /// Mean list length over pixels with a non-empty list.
    pub list_len_mean: f64,
    /// Longest list.
    pub list_len_max: u64,
    /// Loading the data (set by the caller).
    pub time_load_s: f64,
    /// Vertex transform, culling and binning.
    pub time_project_s: f64,
    /// Scan conversion, integration and list insertion, without ERT's own
    /// work: `time_scan_phase_s - (ert_update_s + ert_tests_s) / threads`
    /// (exact with one thread). This is the paper's Tsc.
    pub time_scan_s: f64,
    /// Wall time of the whole scan phase, ERT updates and tests included.
    pub time_scan_phase_s: f64,
    /// Final composition.
    pub time_composite_s: f64,
    /// Everything from projection to the finished image (plus load if set).
    pub time_total_s: f64,
    /// Bytes the input holds: the mesh (vertices, tetrahedra, the fields
    /// still loaded) and the normalised scalars.
    pub mesh_bytes: u64,
    /// Bytes of the frame's own lasting structures: the projected vertices
    /// and the bins' entries (a tile's records, built a run at a time, and
    /// its lists come and go with the tile).
    pub frame_bytes: u64,
    /// Worker threads used.
    pub threads: usize,
    /// Integrator name.
    pub integrator: String,
    /// Whether partial composition was on.
    pub partial_composition: bool,
    /// Whether lists were kept in canonical form (`--canonical`).
    pub canonical: bool,
    /// Tile edge in pixels.
    pub tile_size: u32,
    /// Cell order.
    pub cell_order: String,
    /// Tile width and height actually used (ERT aligns tiles to its entries).
    pub tile_dims: [u32; 2],
    /// ERT threshold (1 = off).
    pub ert_threshold: f64,
    /// ERT structure (`flat` / `pyramid`), empty when off.
    pub ert_structure: String,
    /// Flat table: cells tested (`single` / `multi`), empty otherwise.
    pub ert_span: String,
    /// Entry (pyramid: level-0 block) width and height in pixels.
    pub ert_entry_px: [u32; 2],
    /// Update constant C.
    pub ert_update_c: u32,
    /// The per-pixel, per-channel error bound ERT guarantees:
    /// `(1 - threshold) * max(max_radiance, background)` (0 when off).
    pub ert_error_bound: f64,
    /// Cells skipped by ERT in every tile they touch.
    pub cells_skipped_ert: u64,
    /// (cell, tile) pairs skipped by ERT.
    pub cell_tile_pairs_skipped_ert: u64,
    /// Rebuilds of the ERT structures (summed over tiles).
    pub ert_updates: u64,
    /// Time rebuilding the ERT structures, summed over tiles (T_update).
    pub ert_update_s: f64,
    /// Cell tests done.
    pub ert_tests: u64,
    /// Time testing cells, summed over tiles.
    pub ert_tests_s: f64,
    /// `(ert_update_s + ert_tests_s) / threads / time_scan_s`.
    pub ert_overhead_share: f64,
    /// Oracle (with `--oracle`): cells that have a pixel range.
    pub oracle_cells_considered: Option<u64>,
    /// Oracle: cells whose whole pixel range lies behind the final termination depth of every pixel in it.
    pub oracle_cells_skippable: Option<u64>,
    /// Oracle: ray segments (no partial composition) behind their pixel's termination depth.
    pub oracle_segments_behind: Option<u64>,
    /// Oracle: all ray segments (no partial composition).
    pub oracle_segments_total: Option<u64>,
    /// Oracle: `oracle_segments_behind / oracle_segments_total`.
    pub oracle_segments_behind_share: Option<f64>,
    /// `cells_skipped_ert / oracle_cells_skippable`.
    pub ert_share_of_oracle: Option<f64>,
    /// Oracle pass time.
    pub oracle_time_s: Option<f64>,
    /// Projected cell sizes (Fig. 11(3)), from each cell's pixel bounding box
    /// ([`sizes`]): power-of-two histogram of pixels in the box, keys
    /// `"00004-00007"`.
    pub cell_pixels_hist: std::collections::BTreeMap<String, u64>,
    /// Mean pixels in a cell's bounding box.
    pub cell_pixels_mean: f64,
    /// Median pixels in a cell's bounding box.
    pub cell_pixels_p50: u64,
    /// 90th percentile of pixels in a cell's bounding box.
    pub cell_pixels_p90: u64,
    /// Histogram of the bounding box's larger side (the paper's measure).
    pub cell_extent_hist: std::collections::BTreeMap<String, u64>,
    /// Median larger side, pixels.
    pub cell_extent_p50: u64,
    /// 90th percentile of the larger side.
    pub cell_extent_p90: u64,
    /// 99th percentile of the larger side.
    pub cell_extent_p99: u64,
}

/// The per-tile result of scan conversion.
pub struct TileResult {
    /// Its segment lists.
    pub lists: SegmentLists,
    /// Its counters.
    pub counts: ScanCounts,
    /// Cells that turned out degenerate in this tile.
    pub degenerate: u64,
}

/// The scan phase's result: binning, per-tile lists and ERT statistics.
pub struct Frame {
    /// Culling and binning.
    pub binning: bin::Binning,
    /// The projected vertices the binning refers to (records are rebuilt from them).
    pub vertices: project::ProjectedVertices,
    /// Per tile, its lists.
    pub tiles: Vec<TileResult>,
    /// Per tile, what ERT did (empty when off).
    pub ert: Vec<ert::ErtTileStats>,
    /// Tile width and height used.
    pub tile_dims: (u32, u32),
    /// Entry size used by ERT.
    pub entry_px: (u32, u32),
    /// Seconds: projection and binning.
    pub time_project_s: f64,
    /// Seconds: the scan phase (wall).
    pub time_scan_s: f64,
}

/// Projects, bins and scan-converts `input` into per-tile lists (phases 1 and 2).
pub fn scan_frame(input: &RenderInput, opts: &CellOptions) -> Frame {
    let t0 = Instant::now();
    let scene = &input.scene;
    let view = scene.view();
    let tf = PreparedTf::new(&scene.transfer);
    let pv = project::ProjectedVertices::new(&view, &input.mesh.points, &input.s_norm);
    tracing::debug!(
        vertices_s = t0.elapsed().as_secs_f64(),
        "projected the vertices"
    );
    let ert_on = opts.ert.enabled();
    let tile = opts.tile_size.max(1);
    let (tile_dims, entry_px) = if ert_on {
        (
            opts.ert.tile_dims(tile, view.width, view.height),
            opts.ert.entry_px(view.width, view.height),
        )
    } else {
        ((tile, tile), (0, 0))
    };
    let binning = bin::bin_cells_rect(
        &input.mesh.tets,
        &pv,
        &tf,
        tile_dims.0,
        tile_dims.1,
        opts.cell_order,
        // ERT counts cells between rebuilds: it needs the misses too. The
        // oracle replays the bins' records.
        if opts.oracle {
            single::OnePixelMode::Binned
        } else if ert_on {
            single::OnePixelMode::All
        } else {
            single::OnePixelMode::Hits
        },
    );
    let t1 = Instant::now();
    crate::base::cancel::checkpoint();

    let persp = pv.perspective.then(|| pv.rays());
    // Tiles go to the threads heaviest first, each idle thread taking the
    // next one from a shared queue (greedy longest-processing-time list
    // scheduling): the last tiles to start are the light ones, so no thread
    // is left finishing a big tile alone. The work estimate is the bin's
    // cell count; ties keep the tile order. The image does not depend on
    // this order: tiles are independent.
    let mut queue: Vec<usize> = (0..binning.tiles.len()).collect();
    queue.sort_by_key(|&t| std::cmp::Reverse(binning.bins[t].len() + binning.segs(t).len()));
    let mut results: Vec<(usize, TileResult, Option<ert::ErtTileStats>)> = queue
        .into_iter()
        .par_bridge()
        .map_init(Vec::new, |buf, t| {
            crate::base::cancel::checkpoint();
            if ert_on {
                let rect = binning.tiles[t];
                let cells = bin::BinCells::new(&binning, t, &pv, buf);
                let segs = binning.segs(t);
                let (r, e) =
                    ert::scan_tile_ert(persp, &tf, opts, rect, cells, segs, entry_px, tile_dims);
                (t, r, Some(e))
            } else {
                (t, scan_bin(&binning, t, &pv, &tf, opts, buf), None)
            }
        })
        .collect();
    results.sort_unstable_by_key(|r| r.0);
    let t2 = Instant::now();
    let mut tiles = Vec::with_capacity(results.len());
    let mut ert_stats = Vec::new();
    for (_, t, e) in results {
        tiles.push(t);
        ert_stats.extend(e);
    }
    Frame {
        binning,
        vertices: pv,
        tiles,
        ert: ert_stats,
        tile_dims,
        entry_px,
        time_project_s: (t1 - t0).as_secs_f64(),
        time_scan_s: (t2 - t1).as_secs_f64(),
    }
}

/// Renders `input` by cell projection. Uses the current rayon pool.
pub fn render(input: &RenderInput, opts: &CellOptions) -> (Image, CellStats) {
    let t0 = Instant::now();
    let scene = &input.scene;
    let view = scene.view();
    let frame = scan_frame(input, opts);
    let (binning, tiles) = (&frame.binning, &frame.tiles);
    let t2 = Instant::now();

    let mut image = Image::new(view.width, view.height);
    let bg = scene.image.background.map(|c| c as f32);
    // Final composition, tile by tile in parallel, into per-tile pixel blocks.
    let blocks: Vec<Vec<[f32; 4]>> = tiles
        .par_iter()
        .map(|t| {
            t.lists
                .lists()
                .iter()
                .map(|l| {
                    let c = if opts.canonical {
                        crate::base::canonical::composite(l)
                    } else {
                        list::composite(l)
                    };
                    let keep = 1.0 - c.a;
                    [
                        c.rgb[0] + keep * bg[0],
                        c.rgb[1] + keep * bg[1],
                        c.rgb[2] + keep * bg[2],
                        c.a,
                    ]
                })
                .collect()
        })
        .collect();
    for (rect, block) in binning.tiles.iter().zip(blocks) {
        for (idx, p) in block.into_iter().enumerate() {
            let (i, j) = (
                rect.x0 + idx as u32 % rect.width(),
                rect.y0 + idx as u32 / rect.width(),
            );
            image.pixels[(j * view.width + i) as usize] = p;
        }
    }
    let t3 = Instant::now();

    let mut counts = ScanCounts::default();
    let threads = rayon::current_num_threads();
    let mut stats = CellStats {
        cells_total: input.mesh.tets.len() as u64,
        cells_culled_empty: binning.culled_empty,
        cells_culled_offscreen: binning.culled_offscreen,
        cells_no_pixel_centre: binning.no_pixel_centre,
        cells_degenerate: binning.one_pixel_degenerate,
        cell_tile_pairs: binning.pairs(),
        threads,
        integrator: opts.integrator.to_string(),
        partial_composition: opts.partial_composition,
        canonical: opts.canonical,
        tile_size: opts.tile_size,
        cell_order: opts.cell_order.to_string(),
        tile_dims: [frame.tile_dims.0, frame.tile_dims.1],
        ert_threshold: if opts.ert.enabled() {
            f32_to_f64_short(opts.ert.threshold())
        } else {
            1.0
        },
        ..Default::default()
    };
    stats.cells_projected =
        stats.cells_total - stats.cells_culled_empty - stats.cells_culled_offscreen;
    stats.mesh_bytes =
        (input.mesh.heap_bytes() + input.s_norm.capacity() * std::mem::size_of::<f64>()) as u64;
    stats.frame_bytes = (frame.vertices.heap_bytes() + binning.heap_bytes()) as u64;
    for t in tiles {
        counts.add(&t.counts);
        stats.cells_degenerate += t.degenerate;
        for l in t.lists.lists() {
            if !l.is_empty() {
                stats.pixels_covered += 1;
                stats.segments_stored += l.len() as u64;
                stats.list_len_max = stats.list_len_max.max(l.len() as u64);
            }
        }
    }
    stats.pixels_tested = counts.pixels_tested;
    stats.segments_generated = counts.segments_generated;
    stats.segments_merged = counts.segments_merged;
    stats.list_len_mean = if stats.pixels_covered > 0 {
        stats.segments_stored as f64 / stats.pixels_covered as f64
    } else {
        0.0
    };
    stats.time_project_s = frame.time_project_s;
    stats.time_scan_phase_s = frame.time_scan_s;
    stats.time_scan_s = frame.time_scan_s;
    stats.time_composite_s = (t3 - t2).as_secs_f64();
    stats.time_total_s = (t3 - t0).as_secs_f64();
    let sz = sizes::cell_sizes(binning);
    stats.cell_pixels_hist = sz.pixels_hist;
    stats.cell_pixels_mean = sz.pixels_mean;
    stats.cell_pixels_p50 = sz.pixels_p50;
    stats.cell_pixels_p90 = sz.pixels_p90;
    stats.cell_extent_hist = sz.extent_hist;
    stats.cell_extent_p50 = sz.extent_p50;
    stats.cell_extent_p90 = sz.extent_p90;
    stats.cell_extent_p99 = sz.extent_p99;
    if opts.ert.enabled() {
        ert::fill_stats(
            &mut stats,
            &frame,
            opts,
            &scene.transfer,
            scene.image.background,
        );
    }
    if opts.oracle {
        ert::oracle::fill_stats(&mut stats, input, opts);
    }
    (image, stats)
}

/// Scan-converts tile `t` of `binning` without early ray termination: its
/// binned cells (records rebuilt from `pv`, the vertices binned, in `buf`)
/// and the segments its one-pixel cells got at binning.
pub fn scan_bin(
    binning: &bin::Binning,
    t: usize,
    pv: &project::ProjectedVertices,
    tf: &PreparedTf,
    opts: &CellOptions,
    buf: &mut Vec<bin::CellRecord>,
) -> TileResult {
    let persp = pv.perspective.then(|| pv.rays());
    let cells = bin::BinCells::new(binning, t, pv, buf);
    scan_cells(persp, tf, opts, binning.tiles[t], cells, binning.segs(t))
}

/// Scan-converts the cells of one tile, in the given order, into fresh lists.
pub fn scan_tile(
    perspective: Option<project::PerspRays>,
    tf: &PreparedTf,
    opts: &CellOptions,
    rect: crate::base::Rect,
    cells: &[bin::CellRecord],
) -> TileResult {
    scan_cells(perspective, tf, opts, rect, cells, &[])
}

/// [`scan_tile`] of cells handed out a run at a time, merged with the
/// segments of the tile's one-pixel cells (`segs`, made at binning, see
/// [`single`]) in the cells' order, so that each list receives its
/// segments as if every cell had been scanned here.
fn scan_cells(
    perspective: Option<project::PerspRays>,
    tf: &PreparedTf,
    opts: &CellOptions,
    rect: crate::base::Rect,
    mut cells: impl bin::TileCells,
    segs: &[single::PixelSeg],
) -> TileResult {
    let mut lists = SegmentLists::new(rect.width(), rect.height());
    let mut counts = ScanCounts::default();
    let mut degenerate = 0;
    let mut pending = scan::Pending::default();
    {
        let mut target = ScanTarget::new(
            &mut lists,
            rect,
            tf,
            opts.integrator,
            opts.partial_composition,
            opts.canonical,
            &mut counts,
            &mut pending,
        );
        // Both sequences are sorted by the order's key; ties cannot occur
        // (a cell is in one of them).
        let key: fn(u64) -> u64 = match opts.cell_order {
            CellOrder::FrontToBack => |k| k,
            CellOrder::Stored => |k| k & u64::from(u32::MAX),
        };
        let mut segs = segs.iter().peekable();
        let mut emit_before = |k: u64, target: &mut ScanTarget| {
            while let Some(s) = segs.next_if(|s| key(s.order_key()) < k) {
                s.emit(target);
            }
        };
        for start in (0..cells.len()).step_by(bin::RUN) {
            let end = (start + bin::RUN).min(cells.len());
            for c in cells.run(start..end) {
                emit_before(key(bin::order_key(c.near, c.cell)), &mut target);
                degenerate += scan_cell(c, rect, perspective.as_ref(), &mut target);
            }
        }
        for s in segs {
            s.emit(&mut target);
        }
        // Segments are integrated in batches that span cells: finish the last one.
        target.flush();
    }
    TileResult {
        lists,
        counts,
        degenerate,
    }
}

/// Scan-converts cell `c` over its pixels in tile `rect`. Returns 1 if the
/// cell is degenerate and this tile holds its first pixel (so that it is
/// counted once), else 0.
#[inline]
pub fn scan_cell(
    c: &bin::CellRecord,
    rect: crate::base::Rect,
    perspective: Option<&project::PerspRays>,
    target: &mut ScanTarget,
) -> u64 {
    let [i0, i1, j0, j1] = c.range;
    let range = (
        i0.max(rect.x0),
        i1.min(rect.x1 - 1),
        j0.max(rect.y0),
        j1.min(rect.y1 - 1),
    );
    let Some(setup) = setup::setup_tet(c.ids, &c.pos, &c.s) else {
        return u64::from(rect.x0 <= i0 && i0 < rect.x1 && rect.y0 <= j0 && j0 < rect.y1);
    };
    if let Some(rays) = perspective {
        scan::scan_persp(&setup, rays, range, target);
    } else {
        scan::scan_ortho(&setup, range, target);
    }
    0
}

/// `x` as the f64 with the same shortest decimal form (0.9f32 -> 0.9, not 0.8999999761581421).
fn f32_to_f64_short(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(x as f64)
}
