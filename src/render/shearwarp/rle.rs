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
}

/// The three encodings of one volume under one transfer function.
#[derive(Debug, Clone)]
pub struct Encoding<T> {
    /// Indexed by the principal axis (0 = x).
    pub axis: [AxisRle<T>; 3],
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

impl<T: Texel> AxisRle<T> {
    /// Copies `data` (x fastest, `dims`) into the object order of `axes`
    /// (`(i, j, k)` as volume axes) and encodes its runs under `lut`.
    pub fn new(data: &[T], dims: [usize; 3], axes: [usize; 3], lut: &Lut) -> AxisRle<T> {
        let n = axes.map(|a| dims[a]);
        let stride = [1, dims[0], dims[0] * dims[1]];
        let (si, sj, sk) = (stride[axes[0]], stride[axes[1]], stride[axes[2]]);
        let mut voxels = Vec::with_capacity(n[0] * n[1] * n[2]);
        for k in 0..n[2] {
            for j in 0..n[1] {
                let base = k * sk + j * sj;
                voxels.extend((0..n[0]).map(|i| data[base + i * si]));
            }
        }
        let mut a = AxisRle {
            n,
            voxels,
            offsets: Vec::new(),
            runs: Vec::new(),
        };
        a.classify(lut);
        a
    }

    /// Re-encodes the runs under a new transfer function's table.
    pub fn classify(&mut self, lut: &Lut) {
        let [ni, nj, nk] = self.n;
        self.offsets.clear();
        self.runs.clear();
        self.offsets.reserve(nk * (nj - 1) + 1);
        self.offsets.push(0);
        for k in 0..nk {
            for j in 0..nj - 1 {
                let r0 = &self.voxels[(k * nj + j) * ni..][..ni];
                let r1 = &self.voxels[(k * nj + j + 1) * ni..][..ni];
                let row0 = self.runs.len();
                let mut start = None;
                for i in 0..ni - 1 {
                    let q = [r0[i].f(), r0[i + 1].f(), r1[i].f(), r1[i + 1].f()];
                    let lo = q.iter().copied().fold(f32::INFINITY, f32::min);
                    let hi = q.iter().copied().fold(f32::NEG_INFINITY, f32::max);
                    match (cell_opaque(lut, lo, hi), start) {
                        (true, None) => start = Some(i as u32),
                        (false, Some(s)) => {
                            self.runs.push([s, i as u32]);
                            start = None;
                        }
                        _ => {}
                    }
                }
                if let Some(s) = start {
                    self.runs.push([s, (ni - 1) as u32]);
                }
                merge_short_gaps(&mut self.runs, row0);
                self.offsets.push(self.runs.len() as u32);
            }
        }
    }

    /// The runs of cell scanline `j` of slice `k`.
    #[inline]
    pub fn row_runs(&self, k: usize, j: usize) -> &[Run] {
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
        let axis = [0, 1, 2].map(|c| AxisRle::new(data, dims, super::factor::axes(c), lut));
        Encoding { axis }
    }

    /// Re-encodes the runs of all three axes under `lut`.
    pub fn classify(&mut self, lut: &Lut) {
        for a in &mut self.axis {
            a.classify(lut);
        }
    }

    /// Bytes of the three encodings.
    pub fn bytes(&self) -> u64 {
        self.axis.iter().map(AxisRle::bytes).sum()
    }
}
