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

/// Kept-voxel bitmaps of the lines along one axis, with each kept voxel's
/// payload `T` (the renderer's class: extinction and colour) stored line by
/// line, so that the walks read payloads from a compact array instead of
/// the volume in view order (one cache and TLB miss per voxel on diagonal
/// views).
#[derive(Debug, Clone)]
pub struct LineMask<T> {
    /// The axis the lines run along.
    pub axis: usize,
    /// The other two axes, `b < c`.
    pub others: [usize; 2],
    /// Words per line, `⌈n_a / 64⌉`.
    pub words: usize,
    /// `n_b`: line id is `g_b + n_b g_c`.
    n_b: u64,
    bits: Vec<u64>,
    /// Per line `g_b + n_b g_c`: its kept voxels' range in `payload[g_c]`.
    offsets: Vec<[usize; 2]>,
    /// Per `g_c`: the kept voxels' payloads of its `n_b` lines, line by
    /// line, ascending `g_a` within a line (built by one task each).
    payload: Vec<Vec<T>>,
}

impl<T: Copy + Send + Sync> LineMask<T> {
    /// The mask of the voxels for which `keep(idx)` holds over a `dims`
    /// grid, lines along `axis`, with payloads `class(idx)` (`Some` exactly
    /// where `keep` holds; `keep` is the cheap test run on every voxel,
    /// `class` runs on the kept ones only).
    pub fn build(
        dims: [u64; 3],
        axis: usize,
        keep: &(impl Fn(u64) -> bool + Sync),
        class: &(impl Fn(u64) -> Option<T> + Sync),
    ) -> LineMask<T> {
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
        let mut payload = Vec::new();
        let mut offsets = Vec::new();
        if words > 0 && lines > 0 {
            // One chunk per g_c: the n_b lines of that slab (an x-y or x-z
            // slab of memory, or one y-z slab of rows for lines along x).
            // Each chunk keeps its own payloads and line offsets (no serial
            // concatenation of the payloads afterwards).
            let chunks: Vec<(Vec<T>, Vec<[usize; 2]>)> = bits
                .par_chunks_mut(n_b as usize * words)
                .enumerate()
                .map(|(gc, chunk)| {
                    let base = gc as i64 * st[c];
                    let idx =
                        |ga: u64, gb: u64| (base + ga as i64 * st[axis] + gb as i64 * st[b]) as u64;
                    if axis == 0 {
                        // Lines along x: each line is one row of memory.
                        for gb in 0..n_b {
                            let line = &mut chunk[gb as usize * words..][..words];
                            for ga in 0..n_a {
                                if keep(idx(ga, gb)) {
                                    line[(ga / 64) as usize] |= 1 << (ga % 64);
                                }
                            }
                        }
                    } else {
                        // b == 0 (x): rows of memory run across the lines.
                        for ga in 0..n_a {
                            let (w, bit) = ((ga / 64) as usize, 1u64 << (ga % 64));
                            for gb in 0..n_b {
                                if keep(idx(ga, gb)) {
                                    chunk[gb as usize * words + w] |= bit;
                                }
                            }
                        }
                    }
                    // Then the payloads line by line, into a buffer of the
                    // exact size (no reallocation; the slab is small enough
                    // to stay in cache).
                    let kept: usize = chunk.iter().map(|x| x.count_ones() as usize).sum();
                    let mut out = Vec::with_capacity(kept);
                    let mut offs = Vec::with_capacity(n_b as usize);
                    for gb in 0..n_b {
                        let start = out.len();
                        let line = &chunk[gb as usize * words..][..words];
                        for_each_bit(line, 0, n_a, false, |ga, _| {
                            out.extend(class(idx(ga, gb)));
                        });
                        offs.push([start, out.len()]);
                    }
                    // Every kept voxel has its payload, line by line.
                    for (gb, o) in offs.iter().enumerate() {
                        let line = &chunk[gb * words..][..words];
                        let kept: usize = line.iter().map(|x| x.count_ones() as usize).sum();
                        assert_eq!(
                            kept,
                            o[1] - o[0],
                            "class(idx) must be Some exactly where keep(idx)"
                        );
                    }
                    (out, offs)
                })
                .collect();
            offsets.reserve(lines);
            payload.reserve(chunks.len());
            for (pay, offs) in chunks {
                offsets.extend(offs);
                payload.push(pay);
            }
        }
        LineMask {
            axis,
            others,
            words,
            n_b,
            bits,
            offsets,
            payload,
        }
    }

    /// The words of the line through grid coordinates `g` (its `axis`
    /// coordinate is ignored) and the payloads of its kept voxels.
    #[inline]
    pub fn line(&self, g: [u64; 3]) -> (&[u64], &[T]) {
        let g_c = g[self.others[1]] as usize;
        let id = g[self.others[0]] as usize + self.n_b as usize * g_c;
        let [a, b] = self.offsets[id];
        (
            &self.bits[id * self.words..][..self.words],
            &self.payload[g_c][a..b],
        )
    }
}

/// Masks along each axis, built when first asked for.
pub struct Masks<'k, T, P: Fn(u64) -> bool + Sync, K: Fn(u64) -> Option<T> + Sync> {
    dims: [u64; 3],
    keep: &'k P,
    class: &'k K,
    masks: [Option<LineMask<T>>; 3],
    /// Wall seconds spent building masks.
    build_s: f64,
}

impl<'k, T, P, K> Masks<'k, T, P, K>
where
    T: Copy + Send + Sync,
    P: Fn(u64) -> bool + Sync,
    K: Fn(u64) -> Option<T> + Sync,
{
    /// No mask built yet.
    pub fn new(dims: [u64; 3], keep: &'k P, class: &'k K) -> Self {
        Masks {
            dims,
            keep,
            class,
            masks: [None, None, None],
            build_s: 0.0,
        }
    }

    /// The mask along `axis` (built now if needed).
    pub fn get(&mut self, axis: usize) -> &LineMask<T> {
        let (dims, keep, class) = (self.dims, self.keep, self.class);
        let build_s = &mut self.build_s;
        self.masks[axis].get_or_insert_with(|| {
            let t0 = std::time::Instant::now();
            let m = LineMask::build(dims, axis, keep, class);
            *build_s += t0.elapsed().as_secs_f64();
            m
        })
    }

    /// Wall milliseconds spent building the masks so far.
    pub fn build_ms(&self) -> f64 {
        self.build_s * 1e3
    }

    /// How many masks were built (each is one pass over the volume).
    pub fn built(&self) -> usize {
        self.masks.iter().flatten().count()
    }
}

/// Calls `f(g_a, rank)` for each set bit `g_a` of `line` in `[lo, hi)`,
/// ascending (`descending == false`) or descending; `rank` is the number
/// of set bits of the whole line below `g_a` (the payload's position).
#[inline]
pub fn for_each_bit(
    line: &[u64],
    lo: u64,
    hi: u64,
    descending: bool,
    mut f: impl FnMut(u64, usize),
) {
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
    // Set bits below lo.
    let rank_lo = line[..w0]
        .iter()
        .map(|x| x.count_ones() as usize)
        .sum::<usize>()
        + (line[w0] & !(u64::MAX << (lo % 64))).count_ones() as usize;
    if descending {
        let mut rank = rank_lo
            + (w0..=w1)
                .map(|w| masked(w).count_ones() as usize)
                .sum::<usize>();
        for w in (w0..=w1).rev() {
            let mut x = masked(w);
            while x != 0 {
                let b = 63 - x.leading_zeros() as u64;
                rank -= 1;
                f(w as u64 * 64 + b, rank);
                x &= !(1u64 << b);
            }
        }
    } else {
        let mut rank = rank_lo;
        for w in w0..=w1 {
            let mut x = masked(w);
            while x != 0 {
                let b = x.trailing_zeros() as u64;
                f(w as u64 * 64 + b, rank);
                rank += 1;
                x &= x - 1;
            }
        }
    }
}
