//! Distribution of projected cell sizes (the paper's Fig. 11(3)).
//!
//! Computed from each [`CellRecord`]'s pixel range — the bounding box of the
//! pixel centres its projection may cover, clipped to the image — not from
//! exact covered-pixel counts: it is one pass over the binned records after
//! the frame (outside every timed phase), independent of which cells ERT
//! skipped, and the bounding box is what the ERT tests use. For a tetrahedron
//! the box holds about twice the pixels the projection actually covers.
//!
//! Each cell is counted once, in the tile that holds the first pixel of its
//! range. Cells whose box holds no pixel centre are not binned and not
//! counted.

use std::collections::BTreeMap;

use super::bin::Binning;

/// Size statistics of the projected cells.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CellSizes {
    /// Power-of-two histogram of pixels in the box: key `"00004-00007"` = 4..7 pixels.
    pub pixels_hist: BTreeMap<String, u64>,
    /// Mean pixels in the box.
    pub pixels_mean: f64,
    /// Median pixels in the box.
    pub pixels_p50: u64,
    /// 90th percentile of pixels in the box.
    pub pixels_p90: u64,
    /// Power-of-two histogram of the box's larger side (pixels): the paper's
    /// "maximum length in x and y"; key `"00008-00015"` = 8..15 pixels.
    pub extent_hist: BTreeMap<String, u64>,
    /// Median of the larger side.
    pub extent_p50: u64,
    /// 90th percentile of the larger side.
    pub extent_p90: u64,
    /// 99th percentile of the larger side.
    pub extent_p99: u64,
}

/// The key of `v`'s power-of-two bin, zero-padded so keys sort numerically.
pub fn bin_key(v: u64) -> String {
    let v = v.max(1);
    let lo = 1u64 << (63 - v.leading_zeros());
    format!("{:05}-{:05}", lo, 2 * lo - 1)
}

/// The `q`-quantile (0..=1) of `v` (nearest rank); reorders `v`.
fn quantile(v: &mut [u64], q: f64) -> u64 {
    if v.is_empty() {
        return 0;
    }
    let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    *v.select_nth_unstable(k).1
}

/// Size statistics of the cells in `binning`.
pub fn cell_sizes(binning: &Binning) -> CellSizes {
    let mut pixels = Vec::new();
    let mut extents = Vec::new();
    for (rect, cells) in binning.tiles.iter().zip(&binning.bins) {
        for c in cells {
            let [i0, i1, j0, j1] = c.range;
            if !(rect.x0 <= i0 && i0 < rect.x1 && rect.y0 <= j0 && j0 < rect.y1) {
                continue;
            }
            let (w, h) = ((i1 - i0 + 1) as u64, (j1 - j0 + 1) as u64);
            pixels.push(w * h);
            extents.push(w.max(h));
        }
    }
    let mut s = CellSizes::default();
    for &p in &pixels {
        *s.pixels_hist.entry(bin_key(p)).or_insert(0) += 1;
    }
    for &e in &extents {
        *s.extent_hist.entry(bin_key(e)).or_insert(0) += 1;
    }
    if !pixels.is_empty() {
        s.pixels_mean = pixels.iter().sum::<u64>() as f64 / pixels.len() as f64;
    }
    s.pixels_p50 = quantile(&mut pixels, 0.5);
    s.pixels_p90 = quantile(&mut pixels, 0.9);
    s.extent_p50 = quantile(&mut extents, 0.5);
    s.extent_p90 = quantile(&mut extents, 0.9);
    s.extent_p99 = quantile(&mut extents, 0.99);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_are_powers_of_two() {
        assert_eq!(bin_key(1), "00001-00001");
        assert_eq!(bin_key(2), "00002-00003");
        assert_eq!(bin_key(3), "00002-00003");
        assert_eq!(bin_key(15), "00008-00015");
        assert_eq!(bin_key(16), "00016-00031");
    }

    #[test]
    fn quantiles_by_nearest_rank() {
        let mut v: Vec<u64> = (1..=10).collect();
        assert_eq!(quantile(&mut v, 0.5), 5);
        assert_eq!(quantile(&mut v, 0.9), 9);
        assert_eq!(quantile(&mut v, 1.0), 10);
        assert_eq!(quantile(&mut [], 0.5), 0);
    }
}
