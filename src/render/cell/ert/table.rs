//! The paper's ERT table (Conservative Subscreen Termination, §3.1): the
//! tile cut into entries of `ex x ey` pixels; per entry `terminated` (every
//! pixel terminated) and `deepest` (the largest termination depth of its
//! pixels).
//!
//! Both are held in one number: `deepest = max` over the entry's pixel
//! termination depths, where a pixel that is not terminated counts `+inf` —
//! so the entry is terminated exactly when `deepest` is finite. A cell with
//! nearest depth `near` can be skipped when every entry its pixel range covers
//! has `deepest < near`.

/// A flat ERT table over one tile.
#[derive(Debug, Clone)]
pub struct FlatTable {
    /// Tile width and height in pixels.
    size: (u32, u32),
    /// Entry width and height in pixels.
    entry: (u32, u32),
    /// Entries per row and per column.
    n: (u32, u32),
    deepest: Vec<f32>,
    dirty_flag: Vec<bool>,
    dirty: Vec<u32>,
}

/// Largest value of `depth` (row-major, `width` wide) over the pixels
/// `[x0, x1) x [y0, y1)`: an entry's `deepest` (`+inf` if any is not terminated).
pub fn entry_deepest(depth: &[f32], width: u32, x0: u32, x1: u32, y0: u32, y1: u32) -> f32 {
    let mut m = f32::NEG_INFINITY;
    for y in y0..y1 {
        let row = &depth[(y * width + x0) as usize..(y * width + x1) as usize];
        m = row.iter().fold(m, |m, &d| m.max(d));
    }
    m
}

/// `depth < near`; false if either is NaN (so a NaN never skips a cell).
#[inline(always)]
pub fn in_front(depth: f32, near: f32) -> bool {
    depth < near
}

impl FlatTable {
    /// A table over a `width x height` tile with `ex x ey`-pixel entries
    /// (the last row and column may be narrower). Nothing is terminated.
    pub fn new(width: u32, height: u32, ex: u32, ey: u32) -> FlatTable {
        let (ex, ey) = (ex.max(1), ey.max(1));
        let n = (width.div_ceil(ex), height.div_ceil(ey));
        let len = (n.0 * n.1) as usize;
        FlatTable {
            size: (width, height),
            entry: (ex, ey),
            n,
            deepest: vec![f32::INFINITY; len],
            dirty_flag: vec![false; len],
            dirty: Vec::new(),
        }
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.deepest.len()
    }

    /// Whether the table has no entries.
    pub fn is_empty(&self) -> bool {
        self.deepest.is_empty()
    }

    /// Whether every pixel of entry `e` is terminated.
    pub fn terminated(&self, e: usize) -> bool {
        self.deepest[e].is_finite()
    }

    /// The largest termination depth in entry `e` (`+inf` if not terminated).
    pub fn deepest(&self, e: usize) -> f32 {
        self.deepest[e]
    }

    /// Notes that the termination depth of local pixel `(x, y)` changed.
    #[inline]
    pub fn mark(&mut self, x: u32, y: u32) {
        let e = ((y / self.entry.1) * self.n.0 + x / self.entry.0) as usize;
        if !self.dirty_flag[e] {
            self.dirty_flag[e] = true;
            self.dirty.push(e as u32);
        }
    }

    /// Recomputes the marked entries from the per-pixel depths `depth` of the tile.
    pub fn rebuild(&mut self, depth: &[f32]) {
        let (w, h) = self.size;
        for &e in &self.dirty {
            let (ex, ey) = (e % self.n.0, e / self.n.0);
            let (x0, y0) = (ex * self.entry.0, ey * self.entry.1);
            self.deepest[e as usize] = entry_deepest(
                depth,
                w,
                x0,
                (x0 + self.entry.0).min(w),
                y0,
                (y0 + self.entry.1).min(h),
            );
            self.dirty_flag[e as usize] = false;
        }
        self.dirty.clear();
    }

    /// The paper's test: the local pixel range (inclusive) lies inside one
    /// entry, and that entry is terminated with `deepest < near`.
    #[inline]
    pub fn skip_single(&self, range: [u32; 4], near: f32) -> bool {
        let [x0, x1, y0, y1] = range;
        let (e0, e1) = (x0 / self.entry.0, x1 / self.entry.0);
        let (f0, f1) = (y0 / self.entry.1, y1 / self.entry.1);
        e0 == e1 && f0 == f1 && self.deepest[(f0 * self.n.0 + e0) as usize] < near
    }

    /// The multi-entry test: every entry the local pixel range (inclusive)
    /// covers is terminated with `deepest < near`.
    #[inline]
    pub fn skip_multi(&self, range: [u32; 4], near: f32) -> bool {
        let [x0, x1, y0, y1] = range;
        for f in y0 / self.entry.1..=y1 / self.entry.1 {
            for e in x0 / self.entry.0..=x1 / self.entry.0 {
                if !in_front(self.deepest[(f * self.n.0 + e) as usize], near) {
                    return false;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_hold_the_max_and_need_every_pixel() {
        // 4x2 tile, 2x2 entries; pixel depths row-major.
        let inf = f32::INFINITY;
        let depth = [1.0, 2.0, 5.0, inf, 3.0, 1.0, 1.0, 1.0];
        let mut t = FlatTable::new(4, 2, 2, 2);
        for (x, y) in [(0, 0), (3, 1)] {
            t.mark(x, y);
        }
        t.rebuild(&depth);
        assert!(t.terminated(0) && t.deepest(0) == 3.0);
        assert!(!t.terminated(1));
        assert!(t.skip_single([0, 1, 0, 1], 3.5));
        assert!(
            !t.skip_single([0, 1, 0, 1], 3.0),
            "deepest must be strictly in front"
        );
        assert!(!t.skip_single([1, 2, 0, 0], 10.0), "spans two entries");
        assert!(
            !t.skip_multi([1, 2, 0, 0], 10.0),
            "entry 1 is not terminated"
        );
    }

    #[test]
    fn multi_accepts_spanning_cells_when_all_entries_are_terminated() {
        let depth = [1.0, 2.0, 5.0, 4.0, 3.0, 1.0, 1.0, 1.0];
        let mut t = FlatTable::new(4, 2, 2, 2);
        t.mark(0, 0);
        t.mark(2, 0);
        t.rebuild(&depth);
        assert!(t.skip_multi([1, 2, 0, 0], 5.5));
        assert!(!t.skip_multi([1, 2, 0, 0], 5.0));
        assert!(!t.skip_single([1, 2, 0, 0], 5.5));
    }
}
