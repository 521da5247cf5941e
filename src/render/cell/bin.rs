//! Culling and binning: which cells can contribute, and which screen tiles
//! each one touches.
//!
//! A cell is skipped before projection when its scalar interval maps to zero
//! opacity everywhere (an *empty* cell) or when its projected bounding box
//! misses the image (or lies behind the eye). The survivors go, as compact
//! [`BinEntry`]s, into the bins of the fixed-size screen tiles they touch, in
//! stored order or, for [`CellOrder::FrontToBack`](super::CellOrder), by
//! `(nearest depth, cell id)` (a stable radix sort per bin). A tile's [`CellRecord`]s
//! (the cell's vertices gathered, so scan conversion reads memory in order)
//! are rebuilt when the tile is scanned. Either way every pixel sees the same
//! sequence of segments however many threads render the tiles, so the image
//! does not depend on the thread count or the tile size.

use rayon::prelude::*;

pub use super::cull::Culled;
use super::cull::VertexBounds;
use super::fastmath::{fmax, fmin};
use super::grid::TileGrid;
pub use super::grid::{tiles, tiles_rect};
use super::integrate::PreparedTf;
use super::order::CellOrder;
use super::project::ProjectedVertices;
use super::radix;
pub use super::record::{cell_record, near_key, order_key, BinEntry, CellRecord, Range16};
use super::record::{near_of, record_of};
use super::single::{OnePixel, OnePixelMode, OnePixelQueue, OnePixelSink, PixelSeg, FLAT, MISSED};
use crate::base::Rect;

/// Cells per binning task.
const CHUNK: usize = 16 * 1024;

/// The result of culling and binning.
#[derive(Debug, Clone, Default)]
pub struct Binning {
    /// The tiles, row-major.
    pub tiles: Vec<Rect>,
    /// For each tile, the cells whose pixel range touches it, in the
    /// binning's order; [`Binning::records`] rebuilds their records.
    pub bins: Vec<Vec<BinEntry>>,
    /// Cells skipped because their scalar interval has zero opacity.
    pub culled_empty: u64,
    /// Cells skipped because they project outside the image or lie behind the eye.
    pub culled_offscreen: u64,
    /// Cells inside the image whose bounding box contains no pixel centre.
    pub no_pixel_centre: u64,
    /// For each tile, the finished segments of its cells with one pixel
    /// centre, in the binning's order (empty unless the binning made them,
    /// see [`super::single`]).
    pub segs: Vec<Vec<PixelSeg>>,
    /// Cells with one pixel centre scan-converted at binning (hit or
    /// missed): each is one (cell, tile) pair not in `bins`.
    pub one_pixel_cells: u64,
    /// Of those, cells without volume (counted as degenerate).
    pub one_pixel_degenerate: u64,
}

/// Culls `tets` and bins the rest into `tile x tile` tiles.
pub fn bin_cells(
    tets: &[[u32; 4]],
    pv: &ProjectedVertices,
    tf: &PreparedTf,
    tile: u32,
    order: CellOrder,
) -> Binning {
    bin_cells_rect(tets, pv, tf, tile, tile, order, OnePixelMode::Binned)
}

/// A bin's storage, written by several binning tasks at disjoint slots.
struct BinSlots<T>(*mut T);
// SAFETY: the tasks write disjoint slots of the bin (see `scatter`).
unsafe impl<T: Send> Sync for BinSlots<T> {}

/// Culls `tets` and bins the rest into `tw x th` tiles, each tile's cells in
/// `order`.
///
/// Three passes, so that the 100-byte [`CellRecord`]s are never stored for
/// the whole frame (they are rebuilt per tile by [`Binning::records`], where
/// they stay in cache):
/// 1. in parallel chunks, cull every cell and keep the survivors' compact
///    [`BinEntry`]s (cell order);
/// 2. append each entry to the bins of the tiles its range touches: each
///    chunk counts its entries per tile in pass 1, and writes them in
///    parallel at its prefix-sum offset, so every bin is in cell order;
/// 3. for front-to-back order, sort each bin by a stable radix sort of the
///    depth keys, bins in parallel (ties stay in cell order, so the order is
///    `(nearest depth, cell id)`, the same in every tile).
pub fn bin_cells_rect(
    tets: &[[u32; 4]],
    pv: &ProjectedVertices,
    tf: &PreparedTf,
    tw: u32,
    th: u32,
    order: CellOrder,
    one_pixel: OnePixelMode,
) -> Binning {
    let (w, h) = pv.size;
    let rects = tiles_rect(w, h, tw, th);
    let tiles_x = w.div_ceil(tw);
    let full = Rect {
        x0: 0,
        y0: 0,
        x1: w,
        y1: h,
    };
    let grid = TileGrid::new(tw, th, tiles_x);
    let vb = VertexBounds::new(pv);
    // Tile-local pixel indices of one-pixel segments are 16 bits, piece
    // indices below the markers.
    let fast = one_pixel != OnePixelMode::Binned
        && vb.is_some()
        && !pv.perspective
        && u64::from(tw) * u64::from(th) <= 1 << 16
        && tf.piece_count() < usize::from(FLAT);
    let keep_misses = one_pixel == OnePixelMode::All;
    let n_tiles = rects.len();
    let t0 = std::time::Instant::now();
    let parts: Vec<Part> = tets
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut part = Part::new(chunk.len(), n_tiles, fast);
            let mut queue = OnePixelQueue::default();
            let mut sink = SegSink {
                bins: &mut part.segs,
                grid: &grid,
                rects: &rects,
                keep_misses,
            };
            for (k, &ids) in chunk.iter().enumerate() {
                let cell = (c * CHUNK + k) as u32;
                let kept = match &vb {
                    Some(vb) => cull(ids, pv, tf, vb),
                    None => cell_record(cell, ids, pv, tf, full).map(|r| r.range),
                };
                let range = match kept {
                    Ok(range) => range,
                    Err(Culled::Empty) => {
                        part.empty += 1;
                        continue;
                    }
                    Err(Culled::Offscreen) => {
                        part.off += 1;
                        continue;
                    }
                    Err(Culled::NoPixelCentre) => {
                        part.none += 1;
                        continue;
                    }
                };
                let key = near_key(near_of(ids, pv));
                let [i0, i1, j0, j1] = range;
                if fast && i0 == i1 && j0 == j1 {
                    let vertex = |k: usize| {
                        let v = ids[k] as usize;
                        (pv.pos[v], pv.s[v])
                    };
                    queue.push((cell, key), ids, vertex, (i0, j0), tf, &mut sink);
                    continue;
                }
                grid.for_each_row(range, |a, b| {
                    for n in &mut part.cells.counts[a..b] {
                        *n += 1;
                    }
                });
                part.cells.items.push(BinEntry::new(key, cell, range, ids))
            }
            queue.finish(tf, &mut sink);
            part
        })
        .collect();
    drop(vb);
    let t1 = std::time::Instant::now();
    let mut out = Binning {
        tiles: rects,
        ..Default::default()
    };
    for p in &parts {
        out.culled_empty += p.empty;
        out.culled_offscreen += p.off;
        out.no_pixel_centre += p.none;
        out.one_pixel_cells += p.segs.cells;
        out.one_pixel_degenerate += p.segs.degenerate;
    }
    let (mut cells, mut segs): (Vec<_>, Vec<_>) =
        parts.into_iter().map(|p| (p.cells, p.segs.items)).unzip();
    let mut bins = scatter(&mut cells, n_tiles, &grid);
    let mut seg_bins = scatter(&mut segs, n_tiles, &grid);
    let t2 = std::time::Instant::now();
    if order == CellOrder::FrontToBack {
        sort_bins(&mut bins, |e| e.key);
        sort_bins(&mut seg_bins, |e| e.key);
    }
    tracing::debug!(
        cull_s = (t1 - t0).as_secs_f64(),
        scatter_s = (t2 - t1).as_secs_f64(),
        sort_s = t2.elapsed().as_secs_f64(),
        one_pixel_cells = out.one_pixel_cells,
        "binning"
    );
    out.bins = bins;
    out.segs = if fast { seg_bins } else { Vec::new() };
    out
}

/// One binning task's result: its survivors and its cull counts.
struct Part {
    /// Cells kept as bin entries.
    cells: Items<BinEntry>,
    /// One-pixel cells scan-converted here.
    segs: OnePixelBins,
    empty: u64,
    off: u64,
    none: u64,
}

impl Part {
    fn new(cells: usize, n_tiles: usize, fast: bool) -> Part {
        Part {
            cells: Items {
                items: Vec::with_capacity(cells),
                counts: vec![0; n_tiles],
            },
            segs: OnePixelBins {
                items: Items {
                    items: Vec::with_capacity(if fast { cells / 2 } else { 0 }),
                    counts: vec![0; if fast { n_tiles } else { 0 }],
                },
                cells: 0,
                degenerate: 0,
            },
            empty: 0,
            off: 0,
            none: 0,
        }
    }
}

/// A binning task's one-pixel cells: their segments, each with its tile.
struct OnePixelBins {
    items: Items<(u32, PixelSeg)>,
    /// Cells set up (hit, missed or degenerate).
    cells: u64,
    /// Of those, without volume.
    degenerate: u64,
}

/// Files one-pixel results into a task's [`OnePixelBins`].
struct SegSink<'a> {
    bins: &'a mut OnePixelBins,
    grid: &'a TileGrid,
    rects: &'a [Rect],
    /// Bin misses and flat cells too, marked ([`OnePixelMode::All`]).
    keep_misses: bool,
}

impl OnePixelSink for SegSink<'_> {
    #[inline(always)]
    fn take(&mut self, cell: u32, key: u32, (i, j): (u32, u32), found: OnePixel) {
        self.bins.cells += 1;
        let marked = |piece| PixelSeg {
            piece,
            ..PixelSeg::default()
        };
        let seg = match found {
            OnePixel::Hit(seg) => seg,
            OnePixel::Miss if self.keep_misses => marked(MISSED),
            OnePixel::Degenerate if self.keep_misses => marked(FLAT),
            OnePixel::Miss => return,
            OnePixel::Degenerate => {
                self.bins.degenerate += 1;
                return;
            }
        };
        let t = self.grid.tile_of(i, j);
        let r = self.rects[t];
        let idx = (j - r.y0) * r.width() + (i - r.x0);
        let items = &mut self.bins.items;
        items.counts[t] += 1;
        items.items.push((
            t as u32,
            PixelSeg {
                key,
                cell,
                idx: idx as u16,
                ..seg
            },
        ));
    }
}

/// A binning task's items of one kind, in cell order.
struct Items<T> {
    items: Vec<T>,
    /// Per tile, how many of `items` touch it.
    counts: Vec<usize>,
}

/// What goes into a bin: the item as binned, and the tiles it touches.
trait Binned: Copy + Send + Sync {
    /// The bin's element.
    type Out: Copy + Send;
    /// Calls `f(first, end)` for each row of tiles it touches.
    fn rows(&self, grid: &TileGrid, f: impl FnMut(usize, usize));
    /// The element.
    fn out(&self) -> Self::Out;
}

impl Binned for BinEntry {
    type Out = BinEntry;
    #[inline(always)]
    fn rows(&self, grid: &TileGrid, f: impl FnMut(usize, usize)) {
        grid.for_each_row(self.range(), f)
    }
    #[inline(always)]
    fn out(&self) -> BinEntry {
        *self
    }
}

impl Binned for (u32, PixelSeg) {
    type Out = PixelSeg;
    #[inline(always)]
    fn rows(&self, _: &TileGrid, mut f: impl FnMut(usize, usize)) {
        f(self.0 as usize, self.0 as usize + 1)
    }
    #[inline(always)]
    fn out(&self) -> PixelSeg {
        self.1
    }
}

/// Sorts each bin by `key` (front to back), the bins in parallel.
fn sort_bins<T: Copy + Default + Send>(bins: &mut [Vec<T>], key: impl Fn(&T) -> u32 + Sync) {
    bins.par_iter_mut().for_each_init(Vec::new, |scratch, b| {
        radix::sort_by_key_u32(b, scratch, &key)
    });
}

/// Moves the parts' items into per-tile bins. Each part's first slot in
/// each bin is where the parts before it (in cell order) end; the parts
/// then write in parallel, each into its own disjoint slots, so a bin holds
/// its items in cell order, as a sequential pass would. Each part's items
/// are released as soon as they are copied, so the bins filling and the
/// parts not yet copied are never resident twice over.
fn scatter<T: Binned>(parts: &mut [Items<T>], n_tiles: usize, grid: &TileGrid) -> Vec<Vec<T::Out>> {
    if parts.iter().all(|p| p.items.is_empty()) {
        return vec![Vec::new(); n_tiles];
    }
    let mut bins: Vec<Vec<T::Out>> = (0..n_tiles)
        .map(|t| Vec::with_capacity(parts.iter().map(|p| p.counts[t]).sum()))
        .collect();
    let mut next = vec![0usize; n_tiles];
    for p in parts.iter_mut() {
        for (n, c) in next.iter_mut().zip(&mut p.counts) {
            let first = *n;
            *n += *c;
            *c = first;
        }
    }
    let slots: Vec<BinSlots<T::Out>> = bins
        .iter_mut()
        .map(|b| BinSlots(b.spare_capacity_mut().as_mut_ptr().cast()))
        .collect();
    parts.par_iter_mut().for_each(|p| {
        let Items { items, counts } = p;
        for e in items.iter() {
            e.rows(grid, |a, b| {
                for (slot, n) in slots[a..b].iter().zip(&mut counts[a..b]) {
                    // SAFETY: slot `n` of this bin lies below the bin's
                    // capacity (the sum of all parts' counts) and belongs
                    // to this part alone (its prefix range).
                    unsafe { slot.0.add(*n).write(e.out()) };
                    *n += 1;
                }
            });
        }
        crate::base::pages::release(std::mem::take(items));
    });
    for (b, &n) in bins.iter_mut().zip(&next) {
        // SAFETY: the parts wrote every slot `0..n` of the bin above.
        unsafe { b.set_len(n) };
    }
    bins
}

impl Binning {
    /// Bytes the bins hold.
    pub fn heap_bytes(&self) -> usize {
        self.bins.iter().map(|b| b.capacity()).sum::<usize>() * std::mem::size_of::<BinEntry>()
            + self.bins.capacity() * std::mem::size_of::<Vec<BinEntry>>()
            + self.segs.iter().map(|b| b.capacity()).sum::<usize>()
                * std::mem::size_of::<PixelSeg>()
            + self.segs.capacity() * std::mem::size_of::<Vec<PixelSeg>>()
    }

    /// The number of (cell, tile) pairs: cells counted once per tile they touch.
    pub fn pairs(&self) -> u64 {
        self.bins.iter().map(|b| b.len() as u64).sum::<u64>() + self.one_pixel_cells
    }

    /// Tile `t`'s one-pixel segments (empty when the binning made none).
    pub fn segs(&self, t: usize) -> &[PixelSeg] {
        self.segs.get(t).map_or(&[], |v| v)
    }

    /// Rebuilds the records of tile `t`'s cells, in bin order, into `out`
    /// (cleared first). `pv` must be the vertices binned.
    pub fn records(&self, t: usize, pv: &ProjectedVertices, out: &mut Vec<CellRecord>) {
        out.clear();
        out.extend(self.bins[t].iter().map(|e| record_of(e, pv)));
    }
}

/// Cells handed to scan conversion by [`TileCells::run`] at a time: a
/// tile's records are built a run at a time, so they stay in cache and the
/// frame never holds a whole tile's 104-byte records (a 20 M-tet frame's
/// biggest tiles hold 100 k cells and more).
pub const RUN: usize = 4096;

/// A tile's cells in scan order, handed out a run at a time.
pub trait TileCells {
    /// How many cells.
    fn len(&self) -> usize;
    /// Whether there are none.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The records of cells `range` (indices into the tile's order).
    fn run(&mut self, range: std::ops::Range<usize>) -> &[CellRecord];
    /// The front-to-back order key ([`order_key`]) of cell `i`.
    fn order_key(&self, i: usize) -> u64;
}

impl TileCells for &[CellRecord] {
    fn len(&self) -> usize {
        <[CellRecord]>::len(self)
    }
    fn run(&mut self, range: std::ops::Range<usize>) -> &[CellRecord] {
        &self[range]
    }
    fn order_key(&self, i: usize) -> u64 {
        self[i].order_key()
    }
}

/// A bin's cells, their records rebuilt from the projected vertices a run
/// at a time into a reused buffer.
pub struct BinCells<'a> {
    entries: &'a [BinEntry],
    pv: &'a ProjectedVertices,
    buf: &'a mut Vec<CellRecord>,
}

impl<'a> BinCells<'a> {
    /// The cells of bin `t` of `binning`, whose vertices are `pv`.
    pub fn new(
        binning: &'a Binning,
        t: usize,
        pv: &'a ProjectedVertices,
        buf: &'a mut Vec<CellRecord>,
    ) -> BinCells<'a> {
        BinCells {
            entries: &binning.bins[t],
            pv,
            buf,
        }
    }
}

impl TileCells for BinCells<'_> {
    fn len(&self) -> usize {
        self.entries.len()
    }
    fn run(&mut self, range: std::ops::Range<usize>) -> &[CellRecord] {
        self.buf.clear();
        self.buf
            .extend(self.entries[range].iter().map(|e| record_of(e, self.pv)));
        self.buf
    }
    fn order_key(&self, i: usize) -> u64 {
        let e = &self.entries[i];
        (e.key as u64) << 32 | e.cell as u64
    }
}

/// [`cell_record`]'s verdict and the kept cell's pixel range, by the
/// per-vertex bounds `vb` (see [`super::cull`]).
#[inline(always)]
fn cull(
    ids: [u32; 4],
    pv: &ProjectedVertices,
    tf: &PreparedTf,
    vb: &VertexBounds,
) -> Result<[u32; 4], Culled> {
    let [a, b, c, d] = ids.map(|v| v as usize);
    let s = [pv.s[a], pv.s[b], pv.s[c], pv.s[d]];
    // Scalars are finite (the loader checks the field).
    let (lo, hi) = (
        fmin(fmin(s[0], s[1]), fmin(s[2], s[3])),
        fmax(fmax(s[0], s[1]), fmax(s[2], s[3])),
    );
    if tf.is_transparent(lo, hi) {
        return Err(Culled::Empty);
    }
    vb.range(ids)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::transfer::TransferFunction;
    use proptest::prelude::*;

    /// A coordinate anywhere around the image, on a pixel centre or on a
    /// pixel edge.
    fn coord(hi: i32) -> impl Strategy<Value = f32> {
        prop_oneof![
            -4.0f32..(hi + 4) as f32,
            (-3..hi + 3).prop_map(|i| i as f32 + 0.5),
            (-3..hi + 3).prop_map(|i| i as f32),
        ]
    }

    /// A cell: a centre, four offsets (small: under a pixel; or large),
    /// depths (some behind the eye) and scalars.
    fn cell() -> impl Strategy<Value = [([f32; 3], f32); 4]> {
        (
            coord(40),
            coord(30),
            prop_oneof![0.0f32..0.7, 0.0f32..25.0],
            proptest::array::uniform4((-1.0f32..1.0, -1.0f32..1.0, -1.0f32..5.0, 0.0f32..1.0)),
        )
            .prop_map(|(cx, cy, r, v)| v.map(|(dx, dy, z, s)| ([cx + r * dx, cy + r * dy, z], s)))
    }

    proptest! {
        /// The cull by per-vertex bounds gives `cell_record`'s verdict and
        /// range for every cell, by category (empty, off screen, no pixel
        /// centre).
        #[test]
        fn vertex_bounds_cull_equals_cell_record(cells in proptest::collection::vec(cell(), 1..60)) {
            let pos = cells.iter().flat_map(|c| c.map(|v| v.0)).collect();
            let s = cells.iter().flat_map(|c| c.map(|v| v.1)).collect();
            let pv = ProjectedVertices::screen(pos, s, (40, 30));
            // Zero opacity below s = 0.3: cells there are empty.
            let tf = PreparedTf::new(&TransferFunction::from_rows(
                &[[0.0, 1.0, 0.2, 0.1, 0.0], [0.3, 0.3, 0.3, 0.3, 0.0], [1.0, 0.1, 0.4, 1.0, 0.9]],
                5.0,
            ));
            let vb = VertexBounds::new(&pv).expect("a small image");
            let full = Rect { x0: 0, y0: 0, x1: 40, y1: 30 };
            for k in 0..cells.len() as u32 {
                let ids = [4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 3];
                let want = cell_record(k, ids, &pv, &tf, full).map(|r| r.range);
                prop_assert_eq!(cull(ids, &pv, &tf, &vb), want);
            }
        }
    }
}
