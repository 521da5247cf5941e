//! Distribution of projected cell sizes (the paper's Fig. 11(3)).
//!
//! Computed from each [`CellRecord`](super::bin::CellRecord)'s pixel range — the bounding box of the
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

/// Counts per exact value (index = value), grown on demand: cell sizes are
/// small integers, so this is one cheap pass with no sort.
#[derive(Default)]
struct Counts(Vec<u64>);

impl Counts {
    fn add(&mut self, v: u64) {
        self.add_n(v, 1);
    }

    fn add_n(&mut self, v: u64, n: u64) {
        let v = v as usize;
        if v >= self.0.len() {
            self.0.resize(v + 1, 0);
        }
        self.0[v] += n;
    }

    fn total(&self) -> u64 {
        self.0.iter().sum()
    }

    /// Power-of-two histogram (value 0 counts as 1), keyed by [`bin_key`].
    fn histogram(&self) -> BTreeMap<String, u64> {
        let mut bins = [0u64; 64];
        for (v, &n) in self.0.iter().enumerate() {
            bins[63 - (v as u64).max(1).leading_zeros() as usize] += n;
        }
        bins.iter()
            .enumerate()
            .filter(|(_, &n)| n > 0)
            .map(|(k, &n)| (bin_key(1 << k), n))
            .collect()
    }

    /// The `q`-quantile (0..=1), nearest rank; 0 when empty.
    fn quantile(&self, q: f64) -> u64 {
        let total = self.total();
        if total == 0 {
            return 0;
        }
        let rank = ((q * total as f64).ceil() as u64).clamp(1, total);
        let mut seen = 0;
        for (v, &n) in self.0.iter().enumerate() {
            seen += n;
            if seen >= rank {
                return v as u64;
            }
        }
        (self.0.len() - 1) as u64
    }

    fn mean(&self) -> f64 {
        let total = self.total();
        if total == 0 {
            return 0.0;
        }
        let sum: u64 = self.0.iter().enumerate().map(|(v, &n)| v as u64 * n).sum();
        sum as f64 / total as f64
    }
}

/// Size statistics of the cells in `binning`.
pub fn cell_sizes(binning: &Binning) -> CellSizes {
    let mut pixels = Counts::default();
    let mut extents = Counts::default();
    // Cells with one pixel centre scan-converted at binning (not binned).
    pixels.add_n(1, binning.one_pixel_cells);
    extents.add_n(1, binning.one_pixel_cells);
    for (rect, cells) in binning.tiles.iter().zip(&binning.bins) {
        for c in cells {
            let [i0, i1, j0, j1] = c.range();
            if !(rect.x0 <= i0 && i0 < rect.x1 && rect.y0 <= j0 && j0 < rect.y1) {
                continue;
            }
            let (w, h) = ((i1 - i0 + 1) as u64, (j1 - j0 + 1) as u64);
            pixels.add(w * h);
            extents.add(w.max(h));
        }
    }
    CellSizes {
        pixels_hist: pixels.histogram(),
        pixels_mean: pixels.mean(),
        pixels_p50: pixels.quantile(0.5),
        pixels_p90: pixels.quantile(0.9),
        extent_hist: extents.histogram(),
        extent_p50: extents.quantile(0.5),
        extent_p90: extents.quantile(0.9),
        extent_p99: extents.quantile(0.99),
    }
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
    fn histogram_counts_per_bin() {
        let mut c = Counts::default();
        for v in [0, 1, 2, 3, 4, 15, 16] {
            c.add(v);
        }
        let h = c.histogram();
        let want: Vec<(&str, u64)> = vec![
            ("00001-00001", 2),
            ("00002-00003", 2),
            ("00004-00007", 1),
            ("00008-00015", 1),
            ("00016-00031", 1),
        ];
        assert_eq!(
            h.iter().map(|(k, &n)| (k.as_str(), n)).collect::<Vec<_>>(),
            want
        );
    }

    #[test]
    fn quantiles_by_nearest_rank() {
        let mut c = Counts::default();
        for v in 1..=10 {
            c.add(v);
        }
        assert_eq!(c.quantile(0.5), 5);
        assert_eq!(c.quantile(0.9), 9);
        assert_eq!(c.quantile(1.0), 10);
        assert_eq!(c.mean(), 5.5);
        assert_eq!(Counts::default().quantile(0.5), 0);
    }
}
