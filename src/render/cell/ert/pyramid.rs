//! A max-pyramid of termination depths: the tighter conservative test.
//!
//! Level 0 holds one value per `b x b`-pixel block (`b = 1`: per pixel): the
//! largest termination depth of its pixels, `+inf` if any is not terminated
//! (as a flat table entry). Level `k + 1` holds the max of its (up to) four
//! children at level `k`; the top level is a single value. A cell whose local
//! pixel range maps to blocks `[bx0, bx1] x [by0, by1]` is tested at the
//! lowest level `k` where `(bx1 >> k) - (bx0 >> k) <= 1` and likewise for `y`:
//! at most 2 x 2 values, each the max over a region that contains part of the
//! cell's range, so `max < near` proves that every pixel of the range is
//! terminated in front of the cell. The region tested is at most twice the
//! range's extent (plus one block) along each axis: O(1) per cell, and nearly
//! as tight as a per-pixel test of the range.
//!
//! Rebuilding is incremental: the blocks of pixels whose depth changed are
//! recomputed, and a parent only when a child's value changed.

use super::table::in_front;

/// A max-pyramid over one tile.
#[derive(Debug, Clone)]
pub struct Pyramid {
    /// Tile width and height in pixels.
    size: (u32, u32),
    /// Level-0 block width and height in pixels.
    block: (u32, u32),
    /// Per level: width, height (in entries) and the values, row-major.
    levels: Vec<Level>,
}

#[derive(Debug, Clone)]
struct Level {
    w: u32,
    h: u32,
    v: Vec<f32>,
    dirty_flag: Vec<bool>,
    dirty: Vec<u32>,
}

impl Level {
    fn new(w: u32, h: u32) -> Level {
        let n = (w * h) as usize;
        Level {
            w,
            h,
            v: vec![f32::INFINITY; n],
            dirty_flag: vec![false; n],
            dirty: Vec::new(),
        }
    }

    #[inline]
    fn mark(&mut self, x: u32, y: u32) {
        let e = (y * self.w + x) as usize;
        if !self.dirty_flag[e] {
            self.dirty_flag[e] = true;
            self.dirty.push(e as u32);
        }
    }
}

/// The lowest level at which the block range `[x0, x1] x [y0, y1]` spans at
/// most two entries along each axis.
#[inline]
pub fn test_level(x0: u32, x1: u32, y0: u32, y1: u32) -> u32 {
    let mut k = 0;
    while (x1 >> k) - (x0 >> k) > 1 || (y1 >> k) - (y0 >> k) > 1 {
        k += 1;
    }
    k
}

impl Pyramid {
    /// A pyramid over a `width x height` tile with `bx x by`-pixel level-0
    /// entries. Nothing is terminated.
    pub fn new(width: u32, height: u32, bx: u32, by: u32) -> Pyramid {
        let block = (bx.max(1), by.max(1));
        let (mut w, mut h) = (
            width.div_ceil(block.0).max(1),
            height.div_ceil(block.1).max(1),
        );
        let mut levels = vec![Level::new(w, h)];
        while w > 1 || h > 1 {
            w = w.div_ceil(2);
            h = h.div_ceil(2);
            levels.push(Level::new(w, h));
        }
        Pyramid {
            size: (width, height),
            block,
            levels,
        }
    }

    /// Number of levels (the top one is 1 x 1).
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Value of entry `(x, y)` of level `k`: the largest termination depth of
    /// its pixels, `+inf` if one is not terminated.
    pub fn value(&self, k: usize, x: u32, y: u32) -> f32 {
        let l = &self.levels[k];
        l.v[(y * l.w + x) as usize]
    }

    /// Notes that the termination depth of local pixel `(x, y)` changed.
    #[inline]
    pub fn mark(&mut self, x: u32, y: u32) {
        self.levels[0].mark(x / self.block.0, y / self.block.1);
    }

    /// Recomputes the marked level-0 blocks from the per-pixel depths `depth`
    /// and every ancestor whose value may have changed.
    pub fn rebuild(&mut self, depth: &[f32]) {
        self.rebuild_counted(depth);
    }

    /// [`Pyramid::rebuild`], returning the values read: the pixels of every
    /// recomputed level-0 block and the (up to 4) children of every
    /// recomputed ancestor (what the cluster's cost model charges).
    pub fn rebuild_counted(&mut self, depth: &[f32]) -> u64 {
        let mut reads = 0u64;
        let (w, h) = self.size;
        let (bw, bh) = self.block;
        let mut changed: Vec<u32> = Vec::new();
        {
            let l0 = &mut self.levels[0];
            for &e in &l0.dirty {
                let e = e as usize;
                l0.dirty_flag[e] = false;
                let (bx, by) = (e as u32 % l0.w, e as u32 / l0.w);
                reads += (bw * bh) as u64;
                let v = if (bw, bh) == (1, 1) {
                    depth[(by * w + bx) as usize]
                } else {
                    super::table::entry_deepest(
                        depth,
                        w,
                        bx * bw,
                        (bx * bw + bw).min(w),
                        by * bh,
                        (by * bh + bh).min(h),
                    )
                };
                if v != l0.v[e] {
                    l0.v[e] = v;
                    changed.push(e as u32);
                }
            }
            l0.dirty.clear();
        }
        for k in 1..self.levels.len() {
            let (lo, hi) = self.levels.split_at_mut(k);
            let (child, parent) = (&lo[k - 1], &mut hi[0]);
            for &e in &changed {
                parent.mark((e % child.w) / 2, (e / child.w) / 2);
            }
            changed.clear();
            for &e in &parent.dirty {
                let e = e as usize;
                parent.dirty_flag[e] = false;
                let (px, py) = (e as u32 % parent.w, e as u32 / parent.w);
                let mut v = f32::NEG_INFINITY;
                for cy in 2 * py..(2 * py + 2).min(child.h) {
                    for cx in 2 * px..(2 * px + 2).min(child.w) {
                        reads += 1;
                        v = v.max(child.v[(cy * child.w + cx) as usize]);
                    }
                }
                if v != parent.v[e] {
                    parent.v[e] = v;
                    changed.push(e as u32);
                }
            }
            parent.dirty.clear();
            if changed.is_empty() {
                break;
            }
        }
        reads
    }

    /// Whether every pixel of the local range `[x0, x1] x [y0, y1]` (inclusive)
    /// is terminated in front of `near`, tested on at most 2 x 2 entries at
    /// the level [`test_level`] picks; when that fails, once more one level
    /// finer (at most 4 x 4 entries, a region closer to the range).
    #[inline]
    pub fn skip(&self, range: [u32; 4], near: f32) -> bool {
        let (bw, bh) = self.block;
        let [x0, x1, y0, y1] = [range[0] / bw, range[1] / bw, range[2] / bh, range[3] / bh];
        let k = test_level(x0, x1, y0, y1);
        self.all_in_front(k, [x0, x1, y0, y1], near)
            || (k > 0 && self.all_in_front(k - 1, [x0, x1, y0, y1], near))
    }

    /// Whether every level-`k` entry over the level-0 block range `b` has a value `< near`.
    #[inline]
    fn all_in_front(&self, k: u32, b: [u32; 4], near: f32) -> bool {
        let l = &self.levels[k as usize];
        for y in b[2] >> k..=b[3] >> k {
            for x in b[0] >> k..=b[1] >> k {
                if !in_front(l.v[(y * l.w + x) as usize], near) {
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

    fn exact_skip(depth: &[f32], w: u32, r: [u32; 4], near: f32) -> bool {
        (r[2]..=r[3]).all(|y| (r[0]..=r[1]).all(|x| depth[(y * w + x) as usize] < near))
    }

    #[test]
    fn levels_hold_maxima_and_the_test_is_conservative() {
        let (w, h) = (13u32, 7u32);
        let mut depth: Vec<f32> = (0..w * h).map(|i| ((i * 37) % 11) as f32).collect();
        depth[20] = f32::INFINITY;
        for block in [1, 2, 3] {
            let mut p = Pyramid::new(w, h, block, block);
            for y in 0..h {
                for x in 0..w {
                    p.mark(x, y);
                }
            }
            p.rebuild(&depth);
            assert_eq!(p.value(p.levels() - 1, 0, 0), f32::INFINITY);
            for x0 in 0..w {
                for x1 in x0..w {
                    for (y0, y1) in [(0, 0), (1, 3), (2, 6)] {
                        for near in [5.0, 10.5, 11.0] {
                            let r = [x0, x1, y0, y1];
                            if p.skip(r, near) {
                                assert!(
                                    exact_skip(&depth, w, r, near),
                                    "{r:?} {near} block {block}"
                                );
                            }
                        }
                    }
                }
            }
            // A single pixel is tested exactly with per-pixel blocks.
            if block == 1 {
                assert!(p.skip([0, 0, 0, 0], depth[0] + 0.5));
                assert!(!p.skip([0, 0, 0, 0], depth[0]));
            }
        }
    }

    #[test]
    fn incremental_rebuild_matches_a_full_one() {
        let (w, h) = (9u32, 10u32);
        let mut depth = vec![f32::INFINITY; (w * h) as usize];
        let mut inc = Pyramid::new(w, h, 1, 1);
        for step in 0..40u32 {
            let i = (step * 23) % (w * h);
            depth[i as usize] = (step % 7) as f32;
            inc.mark(i % w, i / w);
            if step % 5 == 4 {
                inc.rebuild(&depth);
                let mut full = Pyramid::new(w, h, 1, 1);
                (0..w * h).for_each(|i| full.mark(i % w, i / w));
                full.rebuild(&depth);
                for k in 0..full.levels() {
                    let l = &full.levels[k];
                    assert_eq!(l.v, inc.levels[k].v, "level {k} after step {step}");
                }
            }
        }
    }

    #[test]
    fn test_level_spans_at_most_two() {
        assert_eq!(test_level(0, 1, 0, 0), 0);
        assert_eq!(test_level(1, 2, 0, 0), 0);
        assert_eq!(test_level(0, 2, 0, 0), 1);
        assert_eq!(test_level(1, 4, 0, 0), 2);
        assert_eq!(test_level(3, 4, 0, 0), 0);
        assert_eq!(test_level(0, 3, 5, 5), 1);
    }
}
