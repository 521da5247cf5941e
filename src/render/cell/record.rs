//! A cell as the scan converter sees it: its record ([`CellRecord`]), its
//! compact bin entry ([`BinEntry`]), the front-to-back order key, and the
//! cull that decides whether it is kept ([`cell_record`]).

use super::cull::Culled;
use super::fastmath::{fmax, fmin};
use super::integrate::PreparedTf;
use super::project::ProjectedVertices;
use super::scan::box_pixels;
use crate::base::Rect;

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

/// A cell in a tile's bin: what [`Binning::records`](super::bin::Binning::records) cannot cheaply
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
        let r = self.0;
        [r[0].into(), r[1].into(), r[2].into(), r[3].into()]
    }
}

/// The front-to-back sort key of a cell with nearest depth `near`: the
/// depth, then the cell id. The one key every tile and every cluster node
/// orders by, so that they agree bit for bit.
#[inline]
pub fn order_key(near: f32, cell: u32) -> u64 {
    (near_key(near) as u64) << 32 | cell as u64
}

/// The nearest depth of a cell's vertices: screen depth (orthographic) or
/// distance from the eye (perspective).
#[inline]
pub fn near_depth(pos: &[[f32; 3]; 4], perspective: bool) -> f32 {
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

/// The depth whose [`near_key`] is `k`, bit for bit.
#[inline]
pub fn near_of_key(k: u32) -> f32 {
    f32::from_bits(if k >> 31 == 1 { k & 0x7fff_ffff } else { !k })
}

/// The record of bin entry `e` (`pv` the vertices binned).
#[inline]
pub fn record_of(e: &BinEntry, pv: &ProjectedVertices) -> CellRecord {
    let ids = e.ids;
    let [a, b, c, d] = ids.map(|v| v as usize);
    let pos = [pv.pos[a], pv.pos[b], pv.pos[c], pv.pos[d]];
    CellRecord {
        near: near_depth(&pos, pv.perspective),
        cell: e.cell,
        range: e.range(),
        ids,
        pos,
        s: [pv.s[a], pv.s[b], pv.s[c], pv.s[d]],
    }
}

/// [`near_depth`] of the cell with vertex ids `ids`, reading only what it
/// needs (orthographic: the four depths).
#[inline(always)]
pub fn near_of(ids: [u32; 4], pv: &ProjectedVertices) -> f32 {
    if pv.perspective {
        near_depth(&ids.map(|v| pv.pos[v as usize]), true)
    } else {
        ids.iter()
            .map(|&v| pv.pos[v as usize][2])
            .fold(f32::INFINITY, f32::min)
    }
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
    // Scalars are finite (the loader checks the field).
    let (lo, hi) = (
        fmin(fmin(s[0], s[1]), fmin(s[2], s[3])),
        fmax(fmax(s[0], s[1]), fmax(s[2], s[3])),
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
    let range = if px.iter().any(|p| p[0].is_nan() || p[1].is_nan()) {
        // Straddles the eye plane (perspective): bound by the screen.
        Some((0, w - 1, 0, h - 1))
    } else {
        // No NaN left: plain min/max (the NaN-aware ones cost a blend each).
        let pick =
            |k: usize, f: fn(f32, f32) -> f32| f(f(px[0][k], px[1][k]), f(px[2][k], px[3][k]));
        let bbox = [pick(0, fmin), pick(0, fmax), pick(1, fmin), pick(1, fmax)];
        let [xl, xh, yl, yh] = bbox;
        if xh < 0.0 || yh < 0.0 || xl > w as f32 || yl > h as f32 {
            return Err(Culled::Offscreen);
        }
        box_pixels(bbox, full)
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
