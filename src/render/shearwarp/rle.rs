//! The view-independent encoding (Lacroute's run-length encoded volume):
//! for each of the three principal axes, the scalars in that axis's object
//! order (`k` slices of `j` scanlines of `i` voxels, `i` fastest) and, per
//! scanline of *cells*, the runs of non-transparent cells.
//!
//! Cell `(i, j)` of slice `k` is the 2x2 voxel quad with corner `(i, j)`:
//! every sample the compositor takes between those four voxels is their
//! bilinear interpolation. A cell is **transparent** when the transfer
//! function's opacity is zero for every scalar in `[min, max]` of its four
//! voxels (widened by a few ulps, see [`cell_opaque`]): a bilinear
//! interpolant is a convex combination of its corners, so it never leaves
//! that interval, and a sample whose lookup entry has opacity 0 has the
//! baked colour and opacity `(0, 0, 0, 0)`, so "over" leaves the pixel
//! unchanged bit for bit. Skipping the transparent runs is therefore exact.
//!
//! The scalars are kept (post-classification through the frame's lookup
//! table, as slice3d does) rather than classified RGBA: the image error
//! stays that of interpolating the scalar field, and a transfer-function
//! change only re-runs [`Encoding::classify`].

use rayon::prelude::*;

use crate::render::slicing::blocks::BLOCK;
use crate::render::slicing::lut::ZeroSet;
use crate::render::slicing::MinMaxBlocks;
use crate::render::slicing::{Lut, Texel};

/// A run of cells `[start, end)` of one cell scanline that holds every
/// non-transparent cell of the stretch (and transparent gaps shorter than
/// [`MIN_GAP`]).
pub type Run = [u32; 2];

/// One principal axis's voxels and runs.
#[derive(Debug, Clone)]
pub struct AxisRle<T> {
    /// Voxels along `i`, `j`, `k`.
    pub n: [usize; 3],
    /// The scalars, index `(k n_j + j) n_i + i`.
    pub voxels: Vec<T>,
    /// `runs[offsets[r] .. offsets[r + 1]]` are the runs of cell scanline
    /// `r = k (n_j - 1) + j`.
    pub offsets: Vec<u32>,
    /// The runs, each scanline's in increasing order.
    pub runs: Vec<Run>,
    /// The transfer function's zero-opacity entries the runs skip.
    pub zero: ZeroSet,
    /// After a transfer-function edit that revealed skipped values
    /// ([`Self::reclassify`]): runs per row of min-max blocks, which stand
    /// for `runs` until [`Self::classify`] re-encodes per cell.
    pub block_runs: Option<BlockRuns>,
}

/// Runs over whole min-max blocks ([`MinMaxBlocks`], `B` = [`BLOCK`] cells
/// a side), one list per block row: cell scanline `j` of slice `k` uses
/// block row `(j / B, min(k / B, n_k - 1))`, whose blocks' `[min, max]`
/// bound every voxel of the scanline's cells (a block's range covers its
/// cells' corners, the next layer included). A cell is skipped only when
/// its block is transparent, so the runs are exact, at block granularity.
#[derive(Debug, Clone)]
pub struct BlockRuns {
    /// Block rows along `j` and `k`.
    nb: [usize; 2],
    /// `runs[offsets[r] .. offsets[r + 1]]` are block row `r = b_k n_bj + b_j`'s.
    offsets: Vec<u32>,
    /// In cells.
    runs: Vec<Run>,
}

impl BlockRuns {
    /// The block rows of an axis with object axes `axes` and `n` voxels,
    /// from the blocks' classification `opaque` (x fastest over `nb`).
    pub fn new(n: [usize; 3], axes: [usize; 3], nb: [u64; 3], opaque: &[bool]) -> BlockRuns {
        let b = BLOCK as usize;
        let [nbi, nbj, nbk] = axes.map(|a| nb[a] as usize);
        let stride = [1, nb[0] as usize, (nb[0] * nb[1]) as usize];
        let (si, sj, sk) = (stride[axes[0]], stride[axes[1]], stride[axes[2]]);
        let cells = (n[0] - 1) as u32;
        let mut offsets = Vec::with_capacity(nbj * nbk + 1);
        let mut runs: Vec<Run> = Vec::new();
        offsets.push(0);
        for bk in 0..nbk {
            for bj in 0..nbj {
                let row0 = runs.len();
                for bi in 0..nbi {
                    if !opaque[bi * si + bj * sj + bk * sk] {
                        continue;
                    }
                    let (c0, c1) = ((bi * b) as u32, (((bi + 1) * b) as u32).min(cells));
                    let open = runs.len() > row0;
                    match runs.last_mut() {
                        Some(r) if open && r[1] == c0 => r[1] = c1,
                        _ => runs.push([c0, c1]),
                    }
                }
                offsets.push(runs.len() as u32);
            }
        }
        BlockRuns {
            nb: [nbj, nbk],
            offsets,
            runs,
        }
    }

    /// The runs of cell scanline `j` of slice `k`.
    #[inline]
    fn row(&self, k: usize, j: usize) -> &[Run] {
        let b = BLOCK as usize;
        let r = (k / b).min(self.nb[1] - 1) * self.nb[0] + j / b;
        &self.runs[self.offsets[r] as usize..self.offsets[r + 1] as usize]
    }
}

/// The encodings of one volume under one transfer function, one per
/// principal axis that was asked for.
#[derive(Debug, Clone)]
pub struct Encoding<T> {
    /// Indexed by the principal axis (0 = x); `None`: not built.
    pub axis: [Option<AxisRle<T>>; 3],
}

/// True when the TF's opacity is non-zero somewhere in `[lo, hi]`.
///
/// The interval is widened by 4 ulps of its magnitude: the compositor's
/// f32 lerps of exact corner values stay within `[lo, hi]` up to rounding
/// (exactly for integer voxels), and a wider interval only marks more cells
/// non-transparent, which keeps skipping exact.
#[inline]
pub fn cell_opaque(lut: &Lut, lo: f32, hi: f32) -> bool {
    let e = 4.0 * f32::EPSILON;
    !lut.transparent(lo - e * (lo.abs() + 1.0), hi + e * (hi.abs() + 1.0))
}

/// Transparent gaps shorter than this many cells are kept inside a run:
/// their samples add exactly zero (so the image is the same), and a run
/// start costs more than a few transparent samples.
pub const MIN_GAP: u32 = 4;

/// Merges the runs from `row0` on whose gap is shorter than [`MIN_GAP`].
fn merge_short_gaps(runs: &mut Vec<Run>, row0: usize) {
    let mut w = row0;
    for r in row0..runs.len() {
        if w > row0 && runs[r][0] - runs[w - 1][1] < MIN_GAP {
            runs[w - 1][1] = runs[r][1];
        } else {
            runs[w] = runs[r];
            w += 1;
        }
    }
    runs.truncate(w);
}

/// The lookup entries `[a, b]` (`a <= b`) that a voxel of value `v` spans
/// under [`cell_opaque`]'s widening: `index(v ∓ 4 ulps (|v| + 1))`. The
/// index is monotone in the value, so the entries of a cell's `[min, max]`
/// are the smallest `a` and the largest `b` of its four corners: the test
/// per cell is [`cell_opaque`]'s, bit for bit (`classify_matches_cell_opaque`).
#[inline(always)]
fn widened_entries(lut: &Lut, v: f32) -> [u16; 2] {
    let e = 4.0 * f32::EPSILON;
    let w = e * (v.abs() + 1.0);
    let (a, b) = (lut.index(v - w), lut.index(v + w));
    [a.min(b) as u16, a.max(b) as u16]
}

/// [`widened_entries`] of every voxel of `row` into `out` (through the
/// 256-entry `table` for u8 voxels).
#[inline]
fn row_entries<T: Texel>(
    row: &[T],
    lut: &Lut,
    table: Option<&[[u16; 2]; 256]>,
    out: &mut Vec<[u16; 2]>,
) {
    out.clear();
    out.extend(row.iter().map(|&v| match (v.byte(), table) {
        (Some(b), Some(t)) => t[b as usize],
        _ => widened_entries(lut, v.f()),
    }));
}

/// Appends to `runs` the runs of one cell scanline whose cells are
/// non-transparent where `opaque` says so (cell `i` is the `i`-th item),
/// short gaps merged ([`merge_short_gaps`]).
#[inline]
fn push_runs(opaque: impl Iterator<Item = bool>, runs: &mut Vec<Run>) {
    let row0 = runs.len();
    let mut start = None;
    let mut n = 0;
    for (i, o) in opaque.enumerate() {
        match (o, start) {
            (true, None) => start = Some(i as u32),
            (false, Some(s)) => {
                runs.push([s, i as u32]);
                start = None;
            }
            _ => {}
        }
        n = i + 1;
    }
    if let Some(s) = start {
        runs.push([s, n as u32]);
    }
    merge_short_gaps(runs, row0);
}

/// Appends to `runs` the runs of the cell scanline between voxel scanlines
/// whose [`widened_entries`] are `e0` and `e1`.
fn scanline_runs(e0: &[[u16; 2]], e1: &[[u16; 2]], lut: &Lut, runs: &mut Vec<Run>) {
    let opaque = (0..e0.len() - 1).map(|i| {
        let q = [e0[i], e0[i + 1], e1[i], e1[i + 1]];
        let a = q[0][0].min(q[1][0]).min(q[2][0]).min(q[3][0]);
        let b = q[0][1].max(q[1][1]).max(q[2][1]).max(q[3][1]);
        !lut.transparent_entries(a as usize, b as usize)
    });
    push_runs(opaque, runs);
}

impl<T: Texel> AxisRle<T> {
    /// Copies `data` (x fastest, `dims`) into the object order of `axes`
    /// (`(i, j, k)` as volume axes) and encodes its runs under `lut`.
    pub fn new(data: &[T], dims: [usize; 3], axes: [usize; 3], lut: &Lut) -> AxisRle<T> {
        let n = axes.map(|a| dims[a]);
        let stride = [1, dims[0], dims[0] * dims[1]];
        let (si, sj, sk) = (stride[axes[0]], stride[axes[1]], stride[axes[2]]);
        let mut voxels = vec![data[0]; n[0] * n[1] * n[2]];
        let slab = n[0] * n[1];
        // Chunks of SLABS output slices go to the threads. Within a chunk the
        // outer loop runs over the axis of the larger input stride: the
        // scanlines read for one outer value then come from one slab of the
        // input, reused from cache across the middle loop (each input cache
        // line serves up to SLABS output slices when `k` is the input's x),
        // instead of a sweep of the whole volume per output slice.
        const SLABS: usize = 64;
        voxels
            .par_chunks_mut(slab * SLABS)
            .enumerate()
            .for_each(|(c, chunk)| {
                let k0 = c * SLABS;
                let kn = chunk.len() / slab;
                let mut fill = |k: usize, j: usize| {
                    let base = (k0 + k) * sk + j * sj;
                    let out = &mut chunk[(k * n[1] + j) * n[0]..][..n[0]];
                    if si == 1 {
                        out.copy_from_slice(&data[base..base + n[0]]);
                    } else {
                        for (i, o) in out.iter_mut().enumerate() {
                            *o = data[base + i * si];
                        }
                    }
                };
                if sj > sk {
                    for j in 0..n[1] {
                        for k in 0..kn {
                            fill(k, j);
                        }
                    }
                } else {
                    for k in 0..kn {
                        for j in 0..n[1] {
                            fill(k, j);
                        }
                    }
                }
            });
        let mut a = AxisRle {
            n,
            voxels,
            offsets: Vec::new(),
            runs: Vec::new(),
            zero: lut.zero_set(),
            block_runs: None,
        };
        a.classify(lut);
        a
    }

    /// True when the runs are exact under `lut`: every cell they skip is
    /// transparent under it too (its zero-opacity entries include the ones
    /// the runs were built for, same scalar mapping).
    pub fn exact_under(&self, lut: &Lut) -> bool {
        self.zero.within(&lut.zero_set())
    }

    /// Makes the runs exact under `lut`: an edit of colours, or of
    /// opacities that stay non-zero where they were (or become zero), keeps
    /// them ([`Self::exact_under`]: a few microseconds); one that makes
    /// transparent values visible replaces them by runs over the min-max
    /// blocks that `opaque` classifies under `lut` ([`BlockRuns`]: exact,
    /// coarser, well under a millisecond), until [`Self::classify`]
    /// re-encodes per cell. Returns true when the runs changed.
    pub fn reclassify(
        &mut self,
        lut: &Lut,
        blocks: &MinMaxBlocks,
        opaque: &[bool],
        axes: [usize; 3],
    ) -> bool {
        if self.exact_under(lut) {
            return false;
        }
        self.block_runs = Some(BlockRuns::new(self.n, axes, blocks.nb, opaque));
        self.zero = lut.zero_set();
        true
    }

    /// Re-encodes the runs under a new transfer function's table (slices in
    /// parallel).
    pub fn classify(&mut self, lut: &Lut) {
        self.zero = lut.zero_set();
        self.block_runs = None;
        let [ni, nj, nk] = self.n;
        let table: Option<[[u16; 2]; 256]> = self.voxels[0]
            .byte()
            .map(|_| std::array::from_fn(|b| widened_entries(lut, b as f32)));
        let voxels = &self.voxels;
        let slices: Vec<(Vec<Run>, Vec<u32>)> = (0..nk)
            .into_par_iter()
            .map(|k| {
                let row = |j: usize| &voxels[(k * nj + j) * ni..][..ni];
                let (mut runs, mut ends) = (Vec::new(), Vec::with_capacity(nj - 1));
                let (mut e0, mut e1) = (Vec::with_capacity(ni), Vec::with_capacity(ni));
                row_entries(row(0), lut, table.as_ref(), &mut e0);
                for j in 0..nj - 1 {
                    row_entries(row(j + 1), lut, table.as_ref(), &mut e1);
                    scanline_runs(&e0, &e1, lut, &mut runs);
                    ends.push(runs.len() as u32);
                    std::mem::swap(&mut e0, &mut e1);
                }
                (runs, ends)
            })
            .collect();
        self.offsets.clear();
        self.runs.clear();
        self.offsets.reserve(nk * (nj - 1) + 1);
        self.offsets.push(0);
        for (runs, ends) in slices {
            let base = self.runs.len() as u32;
            self.offsets.extend(ends.iter().map(|e| base + e));
            self.runs.extend(runs);
        }
    }

    /// The runs of cell scanline `j` of slice `k`.
    #[inline]
    pub fn row_runs(&self, k: usize, j: usize) -> &[Run] {
        if let Some(b) = &self.block_runs {
            return b.row(k, j);
        }
        let r = k * (self.n[1] - 1) + j;
        &self.runs[self.offsets[r] as usize..self.offsets[r + 1] as usize]
    }

    /// Voxel scanline `j` of slice `k`.
    #[inline]
    pub fn row(&self, k: usize, j: usize) -> &[T] {
        &self.voxels[(k * self.n[1] + j) * self.n[0]..][..self.n[0]]
    }

    /// Bytes of voxels and runs.
    pub fn bytes(&self) -> u64 {
        (self.voxels.len() * std::mem::size_of::<T>()
            + self.offsets.len() * 4
            + self.runs.len() * 8) as u64
    }
}

impl<T: Texel> Encoding<T> {
    /// Encodes `data` (x fastest, `dims`) along all three axes.
    pub fn new(data: &[T], dims: [usize; 3], lut: &Lut) -> Encoding<T> {
        Self::for_axes(data, dims, lut, [true; 3])
    }

    /// Encodes `data` along the principal axes `c` with `want[c]`.
    pub fn for_axes(data: &[T], dims: [usize; 3], lut: &Lut, want: [bool; 3]) -> Encoding<T> {
        let axis = [0, 1, 2]
            .map(|c| want[c].then(|| AxisRle::new(data, dims, super::factor::axes(c), lut)));
        Encoding { axis }
    }

    /// Re-encodes the runs of the built axes under `lut`.
    pub fn classify(&mut self, lut: &Lut) {
        for a in self.axis.iter_mut().flatten() {
            a.classify(lut);
        }
    }

    /// [`AxisRle::reclassify`] of the built axes; true when any changed.
    pub fn reclassify(&mut self, lut: &Lut, blocks: &MinMaxBlocks, opaque: &[bool]) -> bool {
        let mut any = false;
        for (c, a) in self.axis.iter_mut().enumerate() {
            if let Some(a) = a {
                any |= a.reclassify(lut, blocks, opaque, super::factor::axes(c));
            }
        }
        any
    }

    /// Bytes of the built encodings.
    pub fn bytes(&self) -> u64 {
        self.axis.iter().flatten().map(AxisRle::bytes).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::TransferFunction;

    /// The runs of one scanline from [`cell_opaque`] on each cell's
    /// `[min, max]`, the definition the fast path must reproduce.
    fn runs_by_definition<T: Texel>(r0: &[T], r1: &[T], lut: &Lut) -> Vec<Run> {
        let opaque = (0..r0.len() - 1).map(|i| {
            let q = [r0[i].f(), r0[i + 1].f(), r1[i].f(), r1[i + 1].f()];
            let lo = q.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = q.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            cell_opaque(lut, lo, hi)
        });
        let mut runs = Vec::new();
        push_runs(opaque, &mut runs);
        runs
    }

    fn check<T: Texel>(data: &[T], dims: [usize; 3], lut: &Lut) {
        for c in 0..3 {
            let ax = super::super::factor::axes(c);
            let a = AxisRle::new(data, dims, ax, lut);
            let [ni, nj, nk] = a.n;
            let stride = [1, dims[0], dims[0] * dims[1]];
            for k in 0..nk {
                for j in 0..nj {
                    let want: Vec<T> = (0..ni)
                        .map(|i| data[i * stride[ax[0]] + j * stride[ax[1]] + k * stride[ax[2]]])
                        .collect();
                    assert!(
                        a.row(k, j).iter().zip(&want).all(|(x, y)| x.f() == y.f()),
                        "axis {c}: voxels of scanline ({j}, {k})"
                    );
                }
                for j in 0..nj - 1 {
                    assert_eq!(
                        a.row_runs(k, j),
                        &runs_by_definition(a.row(k, j), a.row(k, j + 1), lut)[..],
                        "axis {c}: runs of cell scanline ({j}, {k})"
                    );
                }
            }
        }
    }

    #[test]
    fn classify_matches_cell_opaque() {
        // Transparent below 0.3 and in a notch [0.5, 0.7]: a cell's
        // transparency depends on its lowest corner (at the notch's lower
        // edge) and on its highest (at 0.3 and the notch's upper edge).
        let tf = TransferFunction::from_rows(
            &[
                [0.0, 1.0, 1.0, 1.0, 0.0],
                [0.3, 1.0, 1.0, 1.0, 0.0],
                [0.4, 1.0, 0.5, 0.0, 0.2],
                [0.5, 1.0, 0.5, 0.0, 0.0],
                [0.7, 1.0, 0.5, 0.0, 0.0],
                [1.0, 0.0, 0.0, 1.0, 0.6],
            ],
            1.0,
        );
        let dims = [13, 9, 7];
        let n = dims.iter().product::<usize>();
        // Smooth ramps up and down (4, 6 and 8 per voxel along x, y, z: most
        // cells are narrow, many sit on an edge, each corner is a cell's
        // lowest in one of them) and a deterministic scramble of every byte
        // value.
        let ramp: Vec<u8> = (0..n)
            .map(|i| {
                let (x, y, z) = (i % 13, i / 13 % 9, i / 117);
                (60 + 4 * x + 6 * y + 8 * z) as u8
            })
            .collect();
        let falling: Vec<u8> = ramp.iter().map(|v| 255 - v).collect();
        let scramble: Vec<u8> = (0..n)
            .map(|i| ((i * 97 + i / 13 * 31) % 256) as u8)
            .collect();
        for bytes in [ramp, falling, scramble] {
            check(&bytes, dims, &Lut::new(&tf, [0.0, 255.0]));
            let words: Vec<u16> = bytes.iter().map(|&b| b as u16 * 257).collect();
            check(&words, dims, &Lut::new(&tf, [0.0, 65535.0]));
            let floats: Vec<f32> = bytes.iter().map(|&b| b as f32 / 255.0 - 0.1).collect();
            check(&floats, dims, &Lut::new(&tf, [-0.1, 0.9]));
        }
    }
}
