//! The axis and DDA orders over the kept voxels only, from the line masks
//! of [`super::mask`]: the same sequence as the full walk filtered by
//! `keep` (tested), at a cost of `O(N / 64 + kept + n)` instead of one
//! threshold test per voxel. Each kept voxel comes with its payload from
//! the mask (read line by line, not from the volume in view order).
//!
//! - **axis**: slices, rows and voxels far to near as in [`super::axis`]; a
//!   row is a line of the mask along the innermost axis, so its kept voxels
//!   come out of the row's words in order (ascending or descending bits).
//! - **DDA**: by [`super::dda::plane_starts`], the walk draws voxel
//!   `(p, s, r)` (plane, column, row counted from the far side) in outer
//!   iteration `T = J_P(p) + A_S(s) + r`, and within an iteration in
//!   `(p, s)` order. `J_P` and `A_S` are the `d_P` and `d_S` accumulators'
//!   join tables, so the kept voxels, enumerated in `(p, s, r)` order from
//!   the mask's lines along `R` and placed by a stable counting sort on `T`
//!   (`T < J_P(n_P - 1) + A_S(n_S - 1) + n_R <= 3 n`), come out in exactly
//!   the walk's order.

use super::dda::{self, joined, plane_starts};
use super::mask::{for_each_bit, Masks};
use super::{axis, strides, Octant};

/// Appends box `o`'s kept voxels (index, payload) to `out` in the axis order.
pub fn axis_sparse<T, P, K>(
    o: &Octant,
    dims: [u64; 3],
    masks: &mut Masks<T, P, K>,
    out: &mut Vec<(u64, T)>,
) where
    T: Copy + Send + Sync,
    P: Fn(u64) -> bool + Sync,
    K: Fn(u64) -> Option<T> + Sync,
{
    if o.is_empty() {
        return;
    }
    let st = strides(dims);
    let [a0, inner, mid] = axis::axes(o);
    let mask = masks.get(inner);
    let mut g = [0u64; 3];
    let desc = o.far_high[inner];
    for t0 in 0..o.len(a0) {
        g[a0] = o.far_index(a0, t0);
        for tm in 0..o.len(mid) {
            g[mid] = o.far_index(mid, tm);
            let row = g[a0] as i64 * st[a0] + g[mid] as i64 * st[mid];
            let (line, pay) = mask.line(g);
            for_each_bit(line, o.lo[inner], o.hi[inner], desc, |gi, k| {
                out.push(((row + gi as i64 * st[inner]) as u64, pay[k]))
            });
        }
    }
}

/// Appends box `o`'s kept voxels (index, payload) to `out` in the DDA
/// order; `counts` is scratch for the counting sort.
pub fn dda_sparse<T, P, K>(
    o: &Octant,
    dims: [u64; 3],
    masks: &mut Masks<T, P, K>,
    out: &mut Vec<(u64, T)>,
    counts: &mut Vec<usize>,
) where
    T: Copy + Send + Sync + Default,
    P: Fn(u64) -> bool + Sync,
    K: Fn(u64) -> Option<T> + Sync,
{
    if o.is_empty() {
        return;
    }
    let st = strides(dims);
    let [ap, a_s, ar] = dda::axes(o);
    let (n_p, n_s, n_r) = (o.len(ap), o.len(a_s), o.len(ar));
    let (ratio_s, ratio_p) = dda::ratios(o);
    let a_s_tab = joined(ratio_s, n_s);
    let life = a_s_tab[n_s as usize - 1] + n_r;
    let j_p = plane_starts(ratio_p, n_p, life);
    let steps = (j_p[n_p as usize - 1] + life) as usize;
    let mask = masks.get(ar);
    let (lo_r, hi_r, desc) = (o.lo[ar], o.hi[ar], o.far_high[ar]);
    // r (from the far side) of grid coordinate g_r.
    let r_of = |g_r: u64| if desc { hi_r - 1 - g_r } else { g_r - lo_r };
    // Calls f(T, idx, payload) for every kept voxel in (p, s, r) order.
    let each = |f: &mut dyn FnMut(usize, u64, T)| {
        let mut g = [0u64; 3];
        for p in 0..n_p {
            g[ap] = o.far_index(ap, p);
            for s in 0..n_s {
                g[a_s] = o.far_index(a_s, s);
                let t0 = j_p[p as usize] + a_s_tab[s as usize];
                let col = g[ap] as i64 * st[ap] + g[a_s] as i64 * st[a_s];
                let (line, pay) = mask.line(g);
                for_each_bit(line, lo_r, hi_r, desc, |g_r, k| {
                    f(
                        (t0 + r_of(g_r)) as usize,
                        (col + g_r as i64 * st[ar]) as u64,
                        pay[k],
                    )
                });
            }
        }
    };
    // Counting sort on T, stable in the enumeration order.
    counts.clear();
    counts.resize(steps + 1, 0);
    each(&mut |t, _, _| counts[t + 1] += 1);
    for t in 0..steps {
        counts[t + 1] += counts[t];
    }
    let base = out.len();
    out.resize(base + counts[steps], (0, T::default()));
    let dst = &mut out[base..];
    each(&mut |t, idx, pay| {
        dst[counts[t]] = (idx, pay);
        counts[t] += 1;
    });
}
