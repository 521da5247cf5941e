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

use super::integrate::PreparedTf;
use super::order::CellOrder;
use super::project::ProjectedVertices;
use super::radix;
use super::scan::covered_pixels;
use crate::base::Rect;

/// Cells per binning task.
const CHUNK: usize = 16 * 1024;

/// A cell as scan conversion needs it, gathered in one place.
#[derive(Debug, Clone, Copy)]
pub struct CellRecord {
    /// Nearest depth of its vertices (screen depth, or distance from the eye).
    pub near: f32,
    /// Cell index in the mesh.
    pub cell: u32,
    /// Covered pixel range in the whole image, inclusive: `i0, i1, j0, j1`.
    pub range: [u32; 4],
    /// Global vertex ids (for the watertight face set-up).
    pub ids: [u32; 4],
    /// Vertex positions (screen space or camera frame).
    pub pos: [[f32; 3]; 4],
    /// Vertex scalars.
    pub s: [f32; 4],
}

impl CellRecord {
    /// Sort key for front-to-back order: nearest depth, then cell id.
    #[inline]
    pub fn order_key(&self) -> u64 {
        order_key(self.near, self.cell)
    }
}

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
}

/// Splits a `width x height` image into `tile x tile` rectangles, row-major.
pub fn tiles(width: u32, height: u32, tile: u32) -> Vec<Rect> {
    tiles_rect(width, height, tile, tile)
}

/// Splits a `width x height` image into `tw x th` rectangles, row-major
/// (early ray termination aligns tiles to its table entries).
pub fn tiles_rect(width: u32, height: u32, tw: u32, th: u32) -> Vec<Rect> {
    let mut out = Vec::new();
    for y0 in (0..height).step_by(th as usize) {
        for x0 in (0..width).step_by(tw as usize) {
            out.push(Rect {
                x0,
                y0,
                x1: (x0 + tw).min(width),
                y1: (y0 + th).min(height),
            });
        }
    }
    out
}

/// Culls `tets` and bins the rest into `tile x tile` tiles.
pub fn bin_cells(
    tets: &[[u32; 4]],
    pv: &ProjectedVertices,
    tf: &PreparedTf,
    tile: u32,
    order: CellOrder,
) -> Binning {
    bin_cells_rect(tets, pv, tf, tile, tile, order)
}

/// A cell in a tile's bin: what [`Binning::records`] cannot cheaply
/// recompute from the vertices.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C)]
pub struct BinEntry {
    /// Order key: [`near_key`] of the nearest depth.
    pub key: u32,
    /// Cell index in the mesh.
    pub cell: u32,
    /// Covered pixel range in the whole image (16 bits an index: the entry
    /// is 32 bytes, not 40; [`BinEntry::range`] widens it).
    range16: Range16,
    /// Global vertex ids (carried along: reading them back from the mesh in
    /// depth order would be a cache miss per cell).
    pub ids: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<BinEntry>() == 32);

impl BinEntry {
    /// Entry of a cell with order key `key` covering pixel range `range`
    /// (inclusive, every index below 65536).
    #[inline]
    pub fn new(key: u32, cell: u32, range: [u32; 4], ids: [u32; 4]) -> BinEntry {
        BinEntry {
            key,
            cell,
            range16: Range16::new(range),
            ids,
        }
    }

    /// Covered pixel range in the whole image, inclusive: `i0, i1, j0, j1`.
    #[inline(always)]
    pub fn range(&self) -> [u32; 4] {
        self.range16.get()
    }
}

/// An inclusive pixel range `i0, i1, j0, j1` in 16 bits an index (an image
/// side is at most 65536 pixels): how bins and cluster nodes keep a cell's
/// range for the whole frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Range16([u16; 4]);

impl Range16 {
    /// `range`, every index below 65536.
    #[inline]
    pub fn new(range: [u32; 4]) -> Range16 {
        debug_assert!(range.iter().all(|&r| r <= u16::MAX as u32));
        Range16(range.map(|r| r as u16))
    }

    /// The range, widened.
    #[inline(always)]
    pub fn get(self) -> [u32; 4] {
        self.0.map(u32::from)
    }
}

/// The front-to-back sort key of a cell with nearest depth `near`: the
/// depth, then the cell id. The one key every tile and every cluster node
/// orders by, so that they agree bit for bit.
#[inline]
pub fn order_key(near: f32, cell: u32) -> u64 {
    (near_key(near) as u64) << 32 | cell as u64
}

/// A bin's storage, written by several binning tasks at disjoint slots.
struct BinSlots(*mut BinEntry);
// SAFETY: the tasks write disjoint slots of the bin (see `bin_cells_rect`).
unsafe impl Sync for BinSlots {}

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
    // The tiles of a range, as `(row of tiles, first column, last column)`.
    let tile_rows = |r: [u32; 4]| {
        (r[2] / th..=r[3] / th).map(move |ty| (ty * tiles_x + r[0] / tw, ty * tiles_x + r[1] / tw))
    };
    let n_tiles = rects.len();
    struct Part {
        survivors: Vec<BinEntry>,
        /// Per tile, how many of `survivors` touch it.
        counts: Vec<usize>,
        empty: u64,
        off: u64,
        none: u64,
    }
    let mut parts: Vec<Part> = tets
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut part = Part {
                survivors: Vec::with_capacity(chunk.len()),
                counts: vec![0; n_tiles],
                empty: 0,
                off: 0,
                none: 0,
            };
            for (k, &ids) in chunk.iter().enumerate() {
                let cell = (c * CHUNK + k) as u32;
                match cell_record(cell, ids, pv, tf, full) {
                    Ok(rec) => {
                        for (a, b) in tile_rows(rec.range) {
                            for n in &mut part.counts[a as usize..=b as usize] {
                                *n += 1;
                            }
                        }
                        part.survivors
                            .push(BinEntry::new(near_key(rec.near), cell, rec.range, ids))
                    }
                    Err(Culled::Empty) => part.empty += 1,
                    Err(Culled::Offscreen) => part.off += 1,
                    Err(Culled::NoPixelCentre) => part.none += 1,
                }
            }
            part
        })
        .collect();
    let mut out = Binning {
        tiles: rects,
        ..Default::default()
    };
    // Each part's first slot in each bin: the parts before it, in cell
    // order, fill the bin's front. The parts then write their entries in
    // parallel, each into its own disjoint slots, so a bin holds its cells
    // in cell order, as a sequential pass would.
    let mut bins: Vec<Vec<BinEntry>> = (0..n_tiles)
        .map(|t| Vec::with_capacity(parts.iter().map(|p| p.counts[t]).sum()))
        .collect();
    let mut next = vec![0usize; n_tiles];
    for p in &mut parts {
        for (n, c) in next.iter_mut().zip(&mut p.counts) {
            let first = *n;
            *n += *c;
            *c = first;
        }
    }
    let slots: Vec<BinSlots> = bins
        .iter_mut()
        .map(|b| BinSlots(b.spare_capacity_mut().as_mut_ptr().cast()))
        .collect();
    parts.par_iter_mut().for_each(|p| {
        let Part {
            survivors, counts, ..
        } = p;
        for e in survivors.iter() {
            for (a, b) in tile_rows(e.range()) {
                let r = a as usize..=b as usize;
                for (slot, n) in slots[r.clone()].iter().zip(&mut counts[r]) {
                    // SAFETY: slot `n` of this bin lies below the bin's
                    // capacity (the sum of all parts' counts) and belongs
                    // to this part alone (its prefix range).
                    unsafe { slot.0.add(*n).write(*e) };
                    *n += 1;
                }
            }
        }
        // Copied: its pages go back now, so the bins filling and the parts
        // not yet copied are never resident twice over.
        crate::base::pages::release(std::mem::take(survivors));
    });
    for (b, &n) in bins.iter_mut().zip(&next) {
        // SAFETY: the parts wrote every slot `0..n` of the bin above.
        unsafe { b.set_len(n) };
    }
    for p in &parts {
        out.culled_empty += p.empty;
        out.culled_offscreen += p.off;
        out.no_pixel_centre += p.none;
    }
    if order == CellOrder::FrontToBack {
        bins.par_iter_mut().for_each_init(Vec::new, |scratch, b| {
            radix::sort_by_key_u32(b, scratch, |e| e.key)
        });
    }
    out.bins = bins;
    out
}

/// The nearest depth of a cell's vertices: screen depth (orthographic) or
/// distance from the eye (perspective).
#[inline]
fn near_depth(pos: &[[f32; 3]; 4], perspective: bool) -> f32 {
    if perspective {
        pos.iter()
            .map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt())
            .fold(f32::INFINITY, f32::min)
    } else {
        pos.iter().map(|p| p[2]).fold(f32::INFINITY, f32::min)
    }
}

/// Order-preserving map of an `f32` depth onto `u32` (for sorting).
#[inline]
pub fn near_key(near: f32) -> u32 {
    let b = near.to_bits();
    if b >> 31 == 1 {
        !b
    } else {
        b | 0x8000_0000
    }
}

impl Binning {
    /// Bytes the bins hold.
    pub fn heap_bytes(&self) -> usize {
        self.bins.iter().map(|b| b.capacity()).sum::<usize>() * std::mem::size_of::<BinEntry>()
            + self.bins.capacity() * std::mem::size_of::<Vec<BinEntry>>()
    }

    /// The number of (cell, tile) pairs: cells counted once per tile they touch.
    pub fn pairs(&self) -> u64 {
        self.bins.iter().map(|b| b.len() as u64).sum()
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
}

impl TileCells for &[CellRecord] {
    fn len(&self) -> usize {
        <[CellRecord]>::len(self)
    }
    fn run(&mut self, range: std::ops::Range<usize>) -> &[CellRecord] {
        &self[range]
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
}

/// The record of bin entry `e` (`pv` the vertices binned).
#[inline]
fn record_of(e: &BinEntry, pv: &ProjectedVertices) -> CellRecord {
    let ids = e.ids;
    let pos = ids.map(|v| pv.pos[v as usize]);
    CellRecord {
        near: near_depth(&pos, pv.perspective),
        cell: e.cell,
        range: e.range(),
        ids,
        pos,
        s: ids.map(|v| pv.s[v as usize]),
    }
}

/// Why a cell was not turned into a [`CellRecord`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Culled {
    /// Its scalar interval has zero opacity.
    Empty,
    /// Outside the image or behind the eye.
    Offscreen,
    /// Inside the image, but its bounding box holds no pixel centre.
    NoPixelCentre,
}

/// Culls cell `cell` with vertex ids `ids` (indices into `pv`) or gathers
/// its [`CellRecord`]; `full` is the whole image. The record's `ids` are the
/// indices given.
#[inline]
pub fn cell_record(
    cell: u32,
    ids: [u32; 4],
    pv: &ProjectedVertices,
    tf: &PreparedTf,
    full: Rect,
) -> Result<CellRecord, Culled> {
    let s = ids.map(|v| pv.s[v as usize]);
    let (lo, hi) = (
        s.iter().cloned().fold(f32::INFINITY, f32::min),
        s.iter().cloned().fold(f32::NEG_INFINITY, f32::max),
    );
    if tf.is_transparent(lo, hi) {
        return Err(Culled::Empty);
    }
    let (w, h) = pv.size;
    let pos = ids.map(|v| pv.pos[v as usize]);
    if pos.iter().all(|p| p[2] <= 0.0) {
        return Err(Culled::Offscreen); // behind the eye
    }
    let px = ids.map(|v| pv.pixel(v as usize));
    let range = if px.iter().any(|p| p[0].is_nan()) {
        // Straddles the eye plane (perspective): bound by the screen.
        Some((0, w - 1, 0, h - 1))
    } else {
        let (xl, xh) = (
            px.iter().map(|p| p[0]).fold(f32::INFINITY, f32::min),
            px.iter().map(|p| p[0]).fold(f32::NEG_INFINITY, f32::max),
        );
        let (yl, yh) = (
            px.iter().map(|p| p[1]).fold(f32::INFINITY, f32::min),
            px.iter().map(|p| p[1]).fold(f32::NEG_INFINITY, f32::max),
        );
        if xh < 0.0 || yh < 0.0 || xl > w as f32 || yl > h as f32 {
            return Err(Culled::Offscreen);
        }
        covered_pixels(&px, full)
    };
    let Some((i0, i1, j0, j1)) = range else {
        return Err(Culled::NoPixelCentre);
    };
    Ok(CellRecord {
        near: near_depth(&pos, pv.perspective),
        cell,
        range: [i0, i1, j0, j1],
        ids,
        pos,
        s,
    })
}
