//! When the ERT structure is rebuilt: after every `(remaining cells) / C`
//! scan-converted cells (paper §4.2.2), at least one.
//!
//! The cells of a tile are cut into consecutive batches; the structure is
//! rebuilt before each batch but the first (an empty structure skips nothing),
//! and every cell of a batch is tested against the same structure. Testing a
//! whole batch right after the rebuild is therefore exactly the paper's
//! cell-by-cell test, and lets the test time be measured without a clock read
//! per cell.

use std::ops::Range;

/// Cells to scan before the next rebuild, with `remaining` cells left.
#[inline]
pub fn interval(remaining: usize, c: u32) -> usize {
    (remaining / c.max(1) as usize).max(1)
}

/// The batches of `n` cells: `[0, n/C)`, then each `remaining / C` long.
pub fn batches(n: usize, c: u32) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut p = 0;
    while p < n {
        let end = (p + interval(n - p, c)).min(n);
        out.push(p..end);
        p = end;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batches_cover_all_cells_and_shrink() {
        let b = batches(10_000, 100);
        assert_eq!(b[0], 0..100);
        assert_eq!(b[1], 100..199);
        assert_eq!(b.last().unwrap().end, 10_000);
        assert!(b
            .windows(2)
            .all(|w| w[0].end == w[1].start && w[0].len() >= w[1].len()));
        // The last C cells are one per batch.
        assert!(b.iter().rev().take(100).all(|r| r.len() == 1));
        assert!(batches(0, 100).is_empty());
        assert_eq!(batches(5, 1), vec![0..5]);
    }
}
