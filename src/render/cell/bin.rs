//! Culling and binning: which cells can contribute, and which screen tiles
//! each one touches.
//!
//! A cell is skipped before projection when its scalar interval maps to zero
//! opacity everywhere (an *empty* cell) or when its projected bounding box
//! misses the image (or lies behind the eye). The survivors are sorted into
//! fixed-size screen tiles, each tile keeping the cells in their stored order,
//! so every pixel sees the same sequence of segments however many threads
//! render the tiles: the image does not depend on the thread count.

use rayon::prelude::*;

use super::integrate::PreparedTf;
use super::project::ProjectedVertices;
use super::scan::{covered_pixels, Rect};

/// Cells per binning task.
const CHUNK: usize = 16 * 1024;

/// The result of culling and binning.
#[derive(Debug, Clone, Default)]
pub struct Binning {
    /// The tiles, row-major.
    pub tiles: Vec<Rect>,
    /// For each tile, the cells whose pixel range touches it, in stored order.
    pub bins: Vec<Vec<u32>>,
    /// Cells skipped because their scalar interval has zero opacity.
    pub culled_empty: u64,
    /// Cells skipped because they project outside the image or lie behind the eye.
    pub culled_offscreen: u64,
    /// Cells inside the image whose bounding box contains no pixel centre.
    pub no_pixel_centre: u64,
}

/// Splits a `width x height` image into `tile x tile` rectangles, row-major.
pub fn tiles(width: u32, height: u32, tile: u32) -> Vec<Rect> {
    let mut out = Vec::new();
    for y0 in (0..height).step_by(tile as usize) {
        for x0 in (0..width).step_by(tile as usize) {
            out.push(Rect { x0, y0, x1: (x0 + tile).min(width), y1: (y0 + tile).min(height) });
        }
    }
    out
}

/// Culls and bins `tets`, visiting them in `order` (all cells, a permutation)
/// or in stored order when `None`.
pub fn bin_cells(tets: &[[u32; 4]], order: Option<&[u32]>, pv: &ProjectedVertices, tf: &PreparedTf, tile: u32) -> Binning {
    let (w, h) = pv.size;
    let rects = tiles(w, h, tile);
    let tiles_x = w.div_ceil(tile);
    let full = Rect { x0: 0, y0: 0, x1: w, y1: h };
    struct Part {
        pairs: Vec<(u32, u32)>,
        empty: u64,
        off: u64,
        none: u64,
    }
    let n = tets.len();
    let parts: Vec<Part> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let span = c * CHUNK..(c * CHUNK + CHUNK).min(n);
            let mut part = Part { pairs: Vec::with_capacity(span.len() * 5 / 4), empty: 0, off: 0, none: 0 };
            for k in span {
                let cell = order.map_or(k as u32, |o| o[k]);
                let tet = &tets[cell as usize];
                let s = tet.map(|v| pv.s[v as usize]);
                let (lo, hi) = (s.iter().cloned().fold(f32::INFINITY, f32::min), s.iter().cloned().fold(f32::NEG_INFINITY, f32::max));
                if tf.is_transparent(lo, hi) {
                    part.empty += 1;
                    continue;
                }
                let depth = tet.map(|v| pv.pos[v as usize][2]);
                if depth.iter().all(|&z| z <= 0.0) {
                    part.off += 1; // behind the eye
                    continue;
                }
                let px = tet.map(|v| pv.pixel[v as usize]);
                let range = if px.iter().any(|p| p[0].is_nan()) {
                    // Straddles the eye plane (perspective): bound by the screen.
                    Some((0, w - 1, 0, h - 1))
                } else {
                    let (xl, xh) = (px.iter().map(|p| p[0]).fold(f32::INFINITY, f32::min), px.iter().map(|p| p[0]).fold(f32::NEG_INFINITY, f32::max));
                    let (yl, yh) = (px.iter().map(|p| p[1]).fold(f32::INFINITY, f32::min), px.iter().map(|p| p[1]).fold(f32::NEG_INFINITY, f32::max));
                    if xh < 0.0 || yh < 0.0 || xl > w as f32 || yl > h as f32 {
                        part.off += 1;
                        continue;
                    }
                    covered_pixels(&px, full)
                };
                let Some((i0, i1, j0, j1)) = range else {
                    part.none += 1;
                    continue;
                };
                for ty in j0 / tile..=j1 / tile {
                    for tx in i0 / tile..=i1 / tile {
                        part.pairs.push((ty * tiles_x + tx, cell));
                    }
                }
            }
            part
        })
        .collect();
    let mut counts = vec![0usize; rects.len()];
    for p in &parts {
        for &(t, _) in &p.pairs {
            counts[t as usize] += 1;
        }
    }
    let mut bins: Vec<Vec<u32>> = counts.iter().map(|&n| Vec::with_capacity(n)).collect();
    let mut out = Binning { tiles: rects, ..Default::default() };
    for p in &parts {
        for &(t, cell) in &p.pairs {
            bins[t as usize].push(cell);
        }
        out.culled_empty += p.empty;
        out.culled_offscreen += p.off;
        out.no_pixel_centre += p.none;
    }
    out.bins = bins;
    out
}
