//! The oracle: how much a perfect ERT test could skip.
//!
//! A second pass renders the frame with ERT off and *without* partial
//! composition, so every list holds one segment per cell and the termination
//! depth of each pixel ([`termination_depth`] of its final list) is as fine
//! as scan conversion can know it. Then:
//!
//! - a cell is *skippable* when every pixel of its pixel range (the bounding
//!   box of its projection, as the ERT tests see it) has a termination depth
//!   `< near` (the cell's nearest depth) — the test ERT does, with perfect,
//!   final knowledge and per-pixel resolution;
//! - a segment lies *behind* when its `z_front >=` its pixel's termination depth.
//!
//! ERT's termination depths are never smaller than the oracle's (its lists
//! know fewer segments, and merged segments end deeper), so every cell ERT
//! skips is skippable: `cells_skipped_ert / oracle_cells_skippable <= 1`.

use std::time::Instant;

use super::termination::termination_depth;
use crate::render::cell::{scan_frame, CellOptions, CellStats, ErtOptions, Frame};
use crate::render::RenderInput;

/// What the oracle found.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct OracleResult {
    /// Cells with a pixel range (scan-converted without ERT).
    pub cells_considered: u64,
    /// Cells entirely behind the termination depth of every pixel in their range.
    pub cells_skippable: u64,
    /// Segments behind their pixel's termination depth.
    pub segments_behind: u64,
    /// All segments.
    pub segments_total: u64,
}

/// Per-pixel termination depths of a whole `width x height` frame, and the
/// segment counts.
pub fn frame_depths(
    frame: &Frame,
    width: u32,
    height: u32,
    threshold: f32,
) -> (Vec<f32>, u64, u64) {
    let mut depth = vec![f32::INFINITY; (width * height) as usize];
    let (mut behind, mut total) = (0, 0);
    for (rect, t) in frame.binning.tiles.iter().zip(&frame.tiles) {
        for (idx, l) in t.lists.lists().iter().enumerate() {
            let (i, j) = (
                rect.x0 + idx as u32 % rect.width(),
                rect.y0 + idx as u32 / rect.width(),
            );
            let d = termination_depth(l, threshold);
            depth[(j * width + i) as usize] = d;
            total += l.len() as u64;
            behind += l.iter().filter(|s| s.z_front >= d).count() as u64;
        }
    }
    (depth, behind, total)
}

/// Whether every pixel of the inclusive range `[i0, i1, j0, j1]` of a
/// `width`-wide depth image has a depth `< near`.
pub fn range_behind(depth: &[f32], width: u32, range: [u32; 4], near: f32) -> bool {
    let [i0, i1, j0, j1] = range;
    (j0..=j1).all(|j| {
        depth[(j * width + i0) as usize..=(j * width + i1) as usize]
            .iter()
            .all(|&d| d < near)
    })
}

/// Runs the oracle pass for `input` with the cell order, tiles and
/// integrator of `opts`, at ERT threshold `threshold`.
pub fn oracle(input: &RenderInput, opts: &CellOptions, threshold: f32) -> OracleResult {
    let o = CellOptions {
        partial_composition: false,
        ert: ErtOptions::OFF,
        oracle: false,
        canonical: false,
        ..*opts
    };
    let frame = scan_frame(input, &o);
    let view = input.scene.view();
    let (depth, segments_behind, segments_total) =
        frame_depths(&frame, view.width, view.height, threshold);
    let mut r = OracleResult {
        segments_behind,
        segments_total,
        ..Default::default()
    };
    let mut cells = Vec::new();
    for (t, rect) in frame.binning.tiles.iter().enumerate() {
        frame.binning.records(t, &frame.vertices, &mut cells);
        for c in &cells {
            let [i0, _, j0, _] = c.range;
            // Count each cell once, in the tile holding its first pixel.
            if rect.x0 <= i0 && i0 < rect.x1 && rect.y0 <= j0 && j0 < rect.y1 {
                r.cells_considered += 1;
                r.cells_skippable += u64::from(range_behind(&depth, view.width, c.range, c.near));
            }
        }
    }
    r
}

/// Runs the oracle at the threshold of `opts.ert` and adds it to `stats`.
pub fn fill_stats(stats: &mut CellStats, input: &RenderInput, opts: &CellOptions) {
    let t = Instant::now();
    let r = oracle(input, opts, opts.ert.threshold());
    stats.oracle_time_s = Some(t.elapsed().as_secs_f64());
    stats.oracle_cells_considered = Some(r.cells_considered);
    stats.oracle_cells_skippable = Some(r.cells_skippable);
    stats.oracle_segments_behind = Some(r.segments_behind);
    stats.oracle_segments_total = Some(r.segments_total);
    stats.oracle_segments_behind_share = Some(if r.segments_total > 0 {
        r.segments_behind as f64 / r.segments_total as f64
    } else {
        0.0
    });
    stats.ert_share_of_oracle = Some(if r.cells_skippable > 0 {
        stats.cells_skipped_ert as f64 / r.cells_skippable as f64
    } else {
        0.0
    });
}
