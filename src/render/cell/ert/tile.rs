//! Scan conversion of one tile with early ray termination.

use std::time::Instant;

use super::pyramid::Pyramid;
use super::schedule;
use super::table::FlatTable;
use super::termination::termination_depth;
use super::{ErtSpan, ErtStructure};
use crate::base::Rect;
use crate::render::cell::bin::{CellRecord, TileCells, RUN};
use crate::render::cell::integrate::PreparedTf;
use crate::render::cell::list::SegmentLists;
use crate::render::cell::order::CellOrder;
use crate::render::cell::project::PerspRays;
use crate::render::cell::record::near_of_key;
use crate::render::cell::scan::{ScanCounts, ScanTarget};
use crate::render::cell::single::{PixelSeg, FLAT, MISSED};
use crate::render::cell::watch::{cannot_cross, Extent};
use crate::render::cell::{scan_cell, CellOptions, TileResult};

/// What ERT did in one tile.
#[derive(Debug, Clone, Default)]
pub struct ErtTileStats {
    /// Rebuilds of the structure.
    pub updates: u64,
    /// Seconds spent rebuilding (walking changed lists, updating entries).
    pub update_s: f64,
    /// Seconds spent testing cells.
    pub tests_s: f64,
    /// Cells tested against the structure (cells are not tested, and the
    /// structure not rebuilt, while no pixel of the tile has terminated in
    /// front of them: see [`scan_tile_ert`]).
    pub tests: u64,
    /// Cells skipped whose whole range lies in this tile.
    pub skipped_whole: u64,
    /// Cells skipped here whose range spans tiles: (cell id, tiles it touches).
    pub skipped_spanning: Vec<(u32, u32)>,
}

enum Structure {
    Flat(FlatTable, ErtSpan),
    Pyramid(Pyramid),
}

impl Structure {
    #[inline]
    fn mark(&mut self, x: u32, y: u32) {
        match self {
            Structure::Flat(t, _) => t.mark(x, y),
            Structure::Pyramid(p) => p.mark(x, y),
        }
    }

    fn rebuild(&mut self, depth: &[f32]) {
        match self {
            Structure::Flat(t, _) => t.rebuild(depth),
            Structure::Pyramid(p) => p.rebuild(depth),
        }
    }

    /// Whether a cell with pixel range `range` (inclusive, whole image) and
    /// nearest depth `near` can be skipped in tile `rect`.
    #[inline]
    fn skip_range(&self, range: [u32; 4], near: f32, rect: Rect) -> bool {
        let [i0, i1, j0, j1] = range;
        let local = [
            i0.max(rect.x0) - rect.x0,
            i1.min(rect.x1 - 1) - rect.x0,
            j0.max(rect.y0) - rect.y0,
            j1.min(rect.y1 - 1) - rect.y0,
        ];
        match self {
            Structure::Flat(t, ErtSpan::Single) => {
                // The whole projection must fit one entry; entries never straddle
                // tiles, so a cell leaving the tile spans several.
                let inside = rect.x0 <= i0 && i1 < rect.x1 && rect.y0 <= j0 && j1 < rect.y1;
                inside && t.skip_single(local, near)
            }
            Structure::Flat(t, ErtSpan::Multi) => t.skip_multi(local, near),
            Structure::Pyramid(p) => p.skip(local, near),
        }
    }
}

/// Counts cell `cell` with pixel range `range`, skipped in this tile.
#[inline]
fn note_skipped(stats: &mut ErtTileStats, cell: u32, range: [u32; 4], tile: (u32, u32)) {
    let [i0, i1, j0, j1] = range;
    let tiles = (i1 / tile.0 - i0 / tile.0 + 1) * (j1 / tile.1 - j0 / tile.1 + 1);
    if tiles == 1 {
        stats.skipped_whole += 1;
    } else {
        stats.skipped_spanning.push((cell, tiles));
    }
}

/// A tile's scan order when some of its cells came from the binning as
/// one-pixel segments ([`PixelSeg`]): item `k < SEG` is the tile's `k`-th
/// binned cell, `SEG | k` its `k`-th segment.
const SEG: u32 = 1 << 31;

/// The nearest vertex depth of the tile's cells (binned or segments): at
/// most every segment's `z_front`; `+inf` for none. In front-to-back order
/// each list's first.
fn nearest(cells: &impl TileCells, segs: &[PixelSeg], order: CellOrder) -> f32 {
    let (n_cells, n_segs) = match order {
        CellOrder::FrontToBack => (cells.len().min(1), segs.len().min(1)),
        CellOrder::Stored => (cells.len(), segs.len()),
    };
    let keys = (0..n_cells).map(|i| cells.order_key(i));
    match keys
        .chain(segs[..n_segs].iter().map(PixelSeg::order_key))
        .min()
    {
        Some(k) => near_of_key((k >> 32) as u32),
        None => f32::INFINITY,
    }
}

/// One item of a tile's scan order.
enum Item<'a> {
    /// A binned cell.
    Cell(&'a CellRecord),
    /// A cell the binning made a one-pixel segment.
    Seg(&'a PixelSeg),
}

/// Calls `f` on the items of one run in scan order: the binned cells
/// `recs` (consecutive cells of the tile) alone, or merged with the
/// segments as `items` orders them ([`SEG`] marks a segment).
#[inline(always)]
fn for_each_item<'a>(
    recs: &'a [CellRecord],
    items: Option<&[u32]>,
    segs: &'a [PixelSeg],
    mut f: impl FnMut(Item<'a>),
) {
    match items {
        None => recs.iter().for_each(|c| f(Item::Cell(c))),
        Some(items) => {
            let mut r = 0;
            for &it in items {
                if it & SEG == 0 {
                    f(Item::Cell(&recs[r]));
                    r += 1;
                } else {
                    f(Item::Seg(&segs[(it & !SEG) as usize]));
                }
            }
        }
    }
}

/// The merge of the tile's binned cells (keys `cell_key(i)`) and its
/// segments by the cell order's key (`key` masks it).
fn merge_order(
    n_cells: usize,
    cell_key: impl Fn(usize) -> u64,
    segs: &[PixelSeg],
    key: fn(u64) -> u64,
    out: &mut Vec<u32>,
) {
    out.clear();
    let (mut c, mut s) = (0, 0);
    while c < n_cells || s < segs.len() {
        let take_cell =
            s == segs.len() || (c < n_cells && key(cell_key(c)) < key(segs[s].order_key()));
        if take_cell {
            out.push(c as u32);
            c += 1;
        } else {
            out.push(SEG | s as u32);
            s += 1;
        }
    }
}

/// Scan-converts the cells of tile `rect` in order, skipping those that ERT
/// proves invisible.
///
/// Back-off where ERT skips nothing: the tile keeps the smallest termination
/// depth of any of its pixels (`min_depth`, infinite while none has
/// terminated). A cell can only be skipped if every pixel it covers
/// terminates in front of its near depth, hence only if `min_depth < near`;
/// cells failing that are not tested, and while no pixel has terminated the
/// structure is neither rebuilt nor are the tests timed. Every skip decision
/// is the one the full test would make, so the image is the same bit for bit. `entry` is the entry (or level-0 block) size in pixels,
/// `tile` the nominal tile size (for counting cells that span tiles).
#[allow(clippy::too_many_arguments)]
pub fn scan_tile_ert(
    perspective: Option<PerspRays>,
    tf: &PreparedTf,
    opts: &CellOptions,
    rect: Rect,
    mut cells: impl TileCells,
    segs: &[PixelSeg],
    entry: (u32, u32),
    tile: (u32, u32),
) -> (TileResult, ErtTileStats) {
    let (w, h) = (rect.width(), rect.height());
    let ert = &opts.ert;
    let mut lists = SegmentLists::new(w, h);
    // One queue for every target of the tile (see ScanTarget::pending).
    let mut pending = crate::render::cell::scan::Pending::default();
    // In an orthographic view the watch starts once a list may have
    // crossed the threshold (`cannot_cross` of the depths spanned so far,
    // kept in `pending.spanned` until then); until then no change can be
    // drained and the update points have nothing to settle. In
    // perspective it watches from the start.
    if perspective.is_some() {
        lists.track_terminations(ert.threshold());
    } else {
        pending.spanned = Some(Extent::new(nearest(&cells, segs, opts.cell_order)));
    }
    let mut counts = ScanCounts::default();
    let mut degenerate = 0;
    // The pixels' termination depths and the structure over them, made
    // when the first pixel terminates (in most tiles of most scenes none
    // does).
    let mut terminated: Option<(Vec<f32>, Structure)> = None;
    let structure = || {
        let st = match ert.structure {
            ErtStructure::Flat => Structure::Flat(FlatTable::new(w, h, entry.0, entry.1), ert.span),
            ErtStructure::Pyramid => Structure::Pyramid(Pyramid::new(w, h, entry.0, entry.1)),
        };
        (vec![f32::INFINITY; (w * h) as usize], st)
    };
    if !ert.backoff {
        // Rebuilt and tested at every point from the start.
        terminated = Some(structure());
    }
    let mut stats = ErtTileStats::default();
    let mut skip: Vec<bool> = Vec::new();
    let mut min_depth = f32::INFINITY;
    // Without back-off every cell is tested after every rebuild.
    let gate = |min_depth: f32| {
        if ert.backoff {
            min_depth
        } else {
            f32::NEG_INFINITY
        }
    };
    // With one-pixel segments from the binning (each cell of the tile, hit,
    // missed or flat, is one of them or a binned cell), the scan order is
    // the merge of both; batches count cells either way, so ERT rebuilds and
    // tests where it did with every cell binned.
    let mut order = Vec::new();
    if !segs.is_empty() {
        let key: fn(u64) -> u64 = match opts.cell_order {
            CellOrder::FrontToBack => |k| k,
            CellOrder::Stored => |k| k & u64::from(u32::MAX),
        };
        merge_order(cells.len(), |i| cells.order_key(i), segs, key, &mut order);
    }
    let n = cells.len() + segs.len();
    // Whether the last batch left changes to drain (segments that cannot
    // change a termination depth may stay queued past a rebuild point).
    let mut to_drain = false;
    for (b, range) in schedule::batches(n, ert.update_c).into_iter().enumerate() {
        let mut gate_now = None;
        if b > 0 {
            let t0 = (gate(min_depth) < f32::INFINITY).then(Instant::now);
            if to_drain {
                lists.drain_changed(|idx, list| {
                    let d = termination_depth(list, ert.threshold());
                    if d == f32::INFINITY {
                        return;
                    }
                    let (depth, st) = terminated.get_or_insert_with(structure);
                    if d < depth[idx] {
                        depth[idx] = d;
                        min_depth = min_depth.min(d);
                        st.mark(idx as u32 % w, idx as u32 / w);
                    }
                });
            }
            let gate = gate(min_depth);
            // Marks exist only once a depth is finite: nothing to rebuild before.
            if let Some((depth, st)) = terminated.as_mut().filter(|_| gate < f32::INFINITY) {
                let t0 = t0.unwrap_or_else(Instant::now);
                st.rebuild(depth);
                stats.update_s += t0.elapsed().as_secs_f64();
                stats.updates += 1;
                gate_now = Some(gate);
            }
        }
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
        // The batch a run at a time: the structure is not rebuilt inside a
        // batch, so testing each run before scanning it decides as testing
        // the whole batch first would.
        for start in range.clone().step_by(RUN) {
            let end = (start + RUN).min(range.end);
            let (recs, items) = if order.is_empty() {
                (cells.run(start..end), None)
            } else {
                let items = &order[start..end];
                // The binned cells among the items are consecutive ones.
                let n_cells = items.iter().filter(|&&it| it & SEG == 0).count();
                let recs = match items.iter().find(|&&it| it & SEG == 0) {
                    Some(&first) => cells.run(first as usize..first as usize + n_cells),
                    None => &[],
                };
                (recs, Some(items))
            };
            skip.clear();
            if let (Some(gate), Some((_, st))) = (gate_now, &terminated) {
                let t1 = Instant::now();
                let mut tested = 0u64;
                for_each_item(recs, items, segs, |item| {
                    let (range, near) = match item {
                        Item::Cell(c) => (c.range, c.near),
                        Item::Seg(sg) => sg.range_near(rect),
                    };
                    skip.push(
                        near > gate && {
                            tested += 1;
                            st.skip_range(range, near, rect)
                        },
                    );
                });
                stats.tests_s += t1.elapsed().as_secs_f64();
                stats.tests += tested;
            }
            let mut k = 0;
            for_each_item(recs, items, segs, |item| {
                let skipped = skip.get(k) == Some(&true);
                k += 1;
                match item {
                    Item::Cell(c) if skipped => note_skipped(&mut stats, c.cell, c.range, tile),
                    Item::Cell(c) => {
                        degenerate += scan_cell(c, rect, perspective.as_ref(), &mut target)
                    }
                    Item::Seg(_) if skipped => stats.skipped_whole += 1,
                    Item::Seg(sg) => match sg.piece {
                        MISSED => {}
                        FLAT => degenerate += 1,
                        _ => sg.emit(&mut target),
                    },
                }
            });
        }
        if range.end == n {
            target.flush();
            continue;
        }
        if let Some(spanned) = target.pending.extent() {
            let dpl = tf.max_depth_per_length();
            if cannot_cross(spanned, dpl, range.end as u64, ert.threshold()) {
                continue;
            }
            // Records the lists that may have crossed already.
            target.lists.track_terminations(ert.threshold());
            target.pending.spanned = None;
        }
        to_drain = target.settle();
    }
    (
        TileResult {
            lists,
            counts,
            degenerate,
        },
        stats,
    )
}
