//! The transparency pre-pass: which voxels are drawn, as bitmaps of grid
//! lines along one axis.
//!
//! For axis `a` (the other two `b < c`), line `(g_b, g_c)` holds `n_a` bits,
//! bit `g_a` set iff voxel `g` is kept (drawn: non-zero extinction). Lines
//! are `⌈n_a / 64⌉` words each, line id `g_b + n_b g_c`. The whole mask is
//! `N / 8` bytes (2 MiB at 256^3), so the sparse walks ([`super::sparse`])
//! find a line's kept voxels with a few word operations instead of testing
//! every voxel's threshold along the view's diagonal (the DDA walk's step
//! (1), which costs a cache miss per voxel on diagonal views).
//!
//! Built once per frame (or per transfer function) by one pass over the
//! volume, split over the outer coordinate `g_c` with rayon; the innermost
//! loop always runs along x, so the voxels are read in memory order.

use rayon::prelude::*;

/// Kept-voxel bitmaps of the lines along one axis.
#[derive(Debug, Clone)]
pub struct LineMask {
    /// The axis the lines run along.
    pub axis: usize,
    /// The other two axes, `b < c`.
    pub others: [usize; 2],
    /// Words per line, `⌈n_a / 64⌉`.
    pub words: usize,
    /// `n_b`: line id is `g_b + n_b g_c`.
    n_b: u64,
    bits: Vec<u64>,
}

impl LineMask {
    /// The mask of `keep` over a `dims` grid, lines along `axis`.
    pub fn build(dims: [u64; 3], axis: usize, keep: &(impl Fn(u64) -> bool + Sync)) -> LineMask {
        let others = match axis {
            0 => [1, 2],
            1 => [0, 2],
            _ => [0, 1],
        };
        let [b, c] = others;
        let words = dims[axis].div_ceil(64) as usize;
        let (n_a, n_b, n_c) = (dims[axis], dims[b], dims[c]);
        let lines = (n_b * n_c) as usize;
        let mut bits = vec![0u64; lines * words];
        let st = super::strides(dims);
        if words > 0 && lines > 0 {
            // One chunk per g_c: the n_b lines of that slab.
            bits.par_chunks_mut(n_b as usize * words)
                .enumerate()
                .for_each(|(gc, chunk)| {
                    let base = gc as i64 * st[c];
                    if axis == 0 {
                        // Lines along x: each line is one row of memory.
                        for gb in 0..n_b {
                            let row = base + gb as i64 * st[b];
                            let line = &mut chunk[gb as usize * words..][..words];
                            for ga in 0..n_a {
                                if keep((row + ga as i64) as u64) {
                                    line[(ga / 64) as usize] |= 1 << (ga % 64);
                                }
                            }
                        }
                    } else {
                        // b == 0 (x): rows of memory run across the lines.
                        for ga in 0..n_a {
                            let row = base + ga as i64 * st[axis];
                            let (w, bit) = ((ga / 64) as usize, 1u64 << (ga % 64));
                            for gb in 0..n_b {
                                if keep((row + gb as i64) as u64) {
                                    chunk[gb as usize * words + w] |= bit;
                                }
                            }
                        }
                    }
                });
        }
        LineMask {
            axis,
            others,
            words,
            n_b,
            bits,
        }
    }

    /// The words of the line through grid coordinates `g` (its `axis`
    /// coordinate is ignored).
    #[inline]
    pub fn line(&self, g: [u64; 3]) -> &[u64] {
        let id = (g[self.others[0]] + self.n_b * g[self.others[1]]) as usize;
        &self.bits[id * self.words..][..self.words]
    }
}

/// Masks along each axis, built when first asked for.
pub struct Masks<'k, K: Fn(u64) -> bool + Sync> {
    dims: [u64; 3],
    keep: &'k K,
    masks: [Option<LineMask>; 3],
}

impl<'k, K: Fn(u64) -> bool + Sync> Masks<'k, K> {
    /// No mask built yet.
    pub fn new(dims: [u64; 3], keep: &'k K) -> Self {
        Masks {
            dims,
            keep,
            masks: [None, None, None],
        }
    }

    /// The mask along `axis` (built now if needed).
    pub fn get(&mut self, axis: usize) -> &LineMask {
        let (dims, keep) = (self.dims, self.keep);
        self.masks[axis].get_or_insert_with(|| LineMask::build(dims, axis, keep))
    }

    /// How many masks were built (each is one pass over the volume).
    pub fn built(&self) -> usize {
        self.masks.iter().flatten().count()
    }
}

/// Calls `f(g_a)` for each set bit of `line` with `g_a` in `[lo, hi)`,
/// ascending (`descending == false`) or descending.
#[inline]
pub fn for_each_bit(line: &[u64], lo: u64, hi: u64, descending: bool, mut f: impl FnMut(u64)) {
    if lo >= hi {
        return;
    }
    let (w0, w1) = ((lo / 64) as usize, ((hi - 1) / 64) as usize);
    // The bits of word `w` inside [lo, hi).
    let masked = |w: usize| {
        let mut x = line[w];
        if w == w0 {
            x &= u64::MAX << (lo % 64);
        }
        if w == w1 {
            let top = (hi - 1) % 64;
            x &= u64::MAX >> (63 - top);
        }
        x
    };
    if descending {
        for w in (w0..=w1).rev() {
            let mut x = masked(w);
            while x != 0 {
                let b = 63 - x.leading_zeros() as u64;
                f(w as u64 * 64 + b);
                x &= !(1u64 << b);
            }
        }
    } else {
        for w in w0..=w1 {
            let mut x = masked(w);
            while x != 0 {
                let b = x.trailing_zeros() as u64;
                f(w as u64 * 64 + b);
                x &= x - 1;
            }
        }
    }
}
