//! The axis and DDA orders over the kept voxels only, from the line masks
//! of [`super::mask`]: the same sequence as the full walk filtered by
//! `keep` (tested), at a cost of `O(N / 64 + kept + n)` instead of one
//! threshold test per voxel. Each kept voxel comes with its payload from
//! the mask (read line by line, not from the volume in view order).
//!
//! - **axis**: slices, rows and voxels far to near as in [`super::axis`]; a
//!   row is a line of the mask along the innermost axis, so its kept voxels
//!   come out of the row's words in order (ascending or descending bits).
//! - **DDA**: by `dda::plane_starts`, the walk draws voxel
//!   `(p, s, r)` (plane, column, row counted from the far side) in outer
//!   iteration `T = J_P(p) + A_S(s) + r`, and within an iteration in
//!   `(p, s)` order. `J_P` and `A_S` are the `d_P` and `d_S` accumulators'
//!   join tables, so the kept voxels, enumerated in `(p, s, r)` order from
//!   the mask's lines along `R` and placed by a stable counting sort on `T`
//!   (`T < J_P(n_P - 1) + A_S(n_S - 1) + n_R <= 3 n`), come out in exactly
//!   the walk's order.
//!
//! Both run in parallel ([`super::scatter`]): the axis order in chunks of
//! slices (one bucket: chunk order is slice order), the DDA order in chunks
//! of planes `P` with the counting sort on `T` done as a parallel stable
//! bucket scatter (per-chunk counts, bucket-major prefix sums): the same
//! sequence as the serial sort. Each kept voxel is mapped by `emit` (the
//! renderer's projection) as it is written.

use super::dda::{self, joined, plane_starts};
use super::mask::{for_each_bit, LineMask, Masks};
use super::scatter::{scatter, Enumerate};
use super::{axis, strides, Octant};

/// Chunks for `n` outer slabs: several per thread (the kept voxels crowd in
/// some slabs), at most one slab each.
fn chunk_count(n: u64) -> usize {
    ((rayon::current_num_threads() * 4) as u64).min(n).max(1) as usize
}

/// Slabs `[lo, hi)` of chunk `c` of `chunks` over `n`.
#[inline]
fn chunk_range(c: usize, chunks: usize, n: u64) -> (u64, u64) {
    (
        n * c as u64 / chunks as u64,
        n * (c as u64 + 1) / chunks as u64,
    )
}

/// The axis order's kept voxels, chunked by slices.
struct AxisLines<'m, T> {
    o: Octant,
    st: [i64; 3],
    axes: [usize; 3],
    mask: &'m LineMask<T>,
    chunks: usize,
}

impl<T: Copy + Send + Sync> Enumerate<(u64, T)> for AxisLines<'_, T> {
    fn each(&self, c: usize, mut f: impl FnMut(usize, (u64, T))) {
        let (o, st) = (&self.o, self.st);
        let [a0, inner, mid] = self.axes;
        let desc = o.far_high[inner];
        let (t_lo, t_hi) = chunk_range(c, self.chunks, o.len(a0));
        let mut g = [0u64; 3];
        for t0 in t_lo..t_hi {
            g[a0] = o.far_index(a0, t0);
            for tm in 0..o.len(mid) {
                g[mid] = o.far_index(mid, tm);
                let row = g[a0] as i64 * st[a0] + g[mid] as i64 * st[mid];
                let (line, pay) = self.mask.line(g);
                for_each_bit(line, o.lo[inner], o.hi[inner], desc, |gi, k| {
                    f(0, ((row + gi as i64 * st[inner]) as u64, pay[k]))
                });
            }
        }
    }
}

/// Appends box `o`'s kept voxels, mapped by `emit(index, payload)`, to
/// `out` in the axis order.
pub fn axis_sparse<T, S, P, K>(
    o: &Octant,
    dims: [u64; 3],
    masks: &mut Masks<T, P, K>,
    emit: &(impl Fn(u64, T) -> S + Sync),
    out: &mut Vec<S>,
) where
    T: Copy + Send + Sync,
    S: Send,
    P: Fn(u64) -> bool + Sync,
    K: Fn(u64) -> Option<T> + Sync,
{
    if o.is_empty() {
        return;
    }
    let axes = axis::axes(o);
    let lines = AxisLines {
        o: *o,
        st: strides(dims),
        axes,
        mask: masks.get(axes[1]),
        chunks: chunk_count(o.len(axes[0])),
    };
    scatter(&lines, lines.chunks, 1, &|(i, t)| emit(i, t), out);
}

/// The DDA order's kept voxels in `(p, s, r)` order, chunked by planes,
/// each with its iteration `T` (module doc) as the bucket.
struct DdaLines<'m, T> {
    o: Octant,
    st: [i64; 3],
    /// `[P, S, R]`.
    axes: [usize; 3],
    /// `A_S(s)`.
    a_s_tab: Vec<u64>,
    /// `J_P(p)`.
    j_p: Vec<u64>,
    mask: &'m LineMask<T>,
    chunks: usize,
}

impl<T: Copy + Send + Sync> Enumerate<(u64, T)> for DdaLines<'_, T> {
    fn each(&self, c: usize, mut f: impl FnMut(usize, (u64, T))) {
        let (o, st) = (&self.o, self.st);
        let [ap, a_s, ar] = self.axes;
        let (lo_r, hi_r, desc) = (o.lo[ar], o.hi[ar], o.far_high[ar]);
        let (p_lo, p_hi) = chunk_range(c, self.chunks, o.len(ap));
        let mut g = [0u64; 3];
        for p in p_lo..p_hi {
            g[ap] = o.far_index(ap, p);
            for s in 0..o.len(a_s) {
                g[a_s] = o.far_index(a_s, s);
                let t0 = self.j_p[p as usize] + self.a_s_tab[s as usize];
                let col = g[ap] as i64 * st[ap] + g[a_s] as i64 * st[a_s];
                let (line, pay) = self.mask.line(g);
                // r (from the far side) of grid coordinate g_r.
                for_each_bit(line, lo_r, hi_r, desc, |g_r, k| {
                    let r = if desc { hi_r - 1 - g_r } else { g_r - lo_r };
                    f(
                        (t0 + r) as usize,
                        ((col + g_r as i64 * st[ar]) as u64, pay[k]),
                    )
                });
            }
        }
    }
}

/// Appends box `o`'s kept voxels, mapped by `emit(index, payload)`, to
/// `out` in the DDA order.
pub fn dda_sparse<T, S, P, K>(
    o: &Octant,
    dims: [u64; 3],
    masks: &mut Masks<T, P, K>,
    emit: &(impl Fn(u64, T) -> S + Sync),
    out: &mut Vec<S>,
) where
    T: Copy + Send + Sync,
    S: Send,
    P: Fn(u64) -> bool + Sync,
    K: Fn(u64) -> Option<T> + Sync,
{
    if o.is_empty() {
        return;
    }
    let axes = dda::axes(o);
    let [ap, a_s, ar] = axes;
    let (n_p, n_s, n_r) = (o.len(ap), o.len(a_s), o.len(ar));
    let (ratio_s, ratio_p) = dda::ratios(o);
    let a_s_tab = joined(ratio_s, n_s);
    let life = a_s_tab[n_s as usize - 1] + n_r;
    let j_p = plane_starts(ratio_p, n_p, life);
    let steps = (j_p[n_p as usize - 1] + life) as usize;
    let lines = DdaLines {
        o: *o,
        st: strides(dims),
        axes,
        a_s_tab,
        j_p,
        mask: masks.get(ar),
        chunks: chunk_count(n_p),
    };
    // The stable counting sort on T, as a parallel bucket scatter.
    scatter(&lines, lines.chunks, steps, &|(i, t)| emit(i, t), out);
}
