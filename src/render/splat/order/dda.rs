//! The paper's view-aligned order without sorting (Takasao, Kanai,
//! Yamaguchi, Fig. 6), with its symbols as names.
//!
//! Axes: the view's weights `w_a` (depth per index step, see [`super::Octant`])
//! sorted so that `w_P >= w_S >= w_R`. In the paper's notation `Δa = 1/|e_a|`
//! and the case `Δz > Δy > Δx` has planes across x (`P`), columns indexed by y
//! inside a plane (`S[plane]`) and running along z (`R`, the least
//! view-parallel axis, one voxel per step).
//!
//! ```text
//! P <- { farthest plane };  d_P <- 0
//! do {
//!   for each plane index in P {
//!     for each column in S[index]: draw its farthest undrawn voxel      (1)
//!     d_S[index] += Δy/Δz            (= w_R / w_S)
//!     if d_S[index] >= 1 { append the farthest unadded column; d_S[index] -= 1 }
//!     if the head column of S[index] is fully drawn: remove it
//!   }
//!   d_P += Δx/Δz                     (= w_R / w_P)
//!   if d_P >= 1 { append the farthest unadded plane to P; d_P -= 1 }
//!   if the head plane of P is fully drawn: remove it
//! } while P is not empty
//! ```
//!
//! A new plane starts with its farthest column in `S` and `d_S = 0` (the 2-D
//! algorithm's step i; Fig. 6 leaves it implicit).
//!
//! **Why it is view-aligned.** One step moves the sweep `w_R` deeper: voxel
//! `(p, s, r)` (counted from the far side) is drawn at step
//! `t = A_P(p) + A_S(s) + r` where plane `p` joins at `A_P(p) in
//! [p w_P/w_R, p w_P/w_R + 1)` and column `s` at `A_S(s)` likewise, so
//! `t w_R in [π, π + 2 w_R)` with `π = p w_P + s w_S + r w_R` the voxel's
//! distance from the far corner plane: a voxel drawn earlier is never more
//! than `2 w_R` nearer than one drawn later (tested).
//!
//! **Why it is back to front.** At most one column (plane) joins per step
//! because the ratios are `<= 1`, so `A_S`, `A_P` strictly increase; hence
//! each voxel's step exceeds its three farther face neighbours' steps. This
//! holds for *any* ratios in `(0, 1]`, which lets us handle degenerate views:
//!
//! - `w_R = 0` (the view is perpendicular to `R`) would stall the walk
//!   (`d_S` never grows). We clamp `d_S`'s increment to at least `1/n_R`
//!   (when `w_R n_R < w_S` a whole column is shallower than one column step,
//!   so drawing columns one after another *is* their depth order), and scale
//!   `d_P`'s increment to the same step depth `h = ratio_S w_S`, clamped to at
//!   least one plane per plane lifetime (`w_S = 0` too: plane after plane).
//!
//! The visit is a callback; the per-plane work is a range of columns
//! `[head, tail)` and a step counter `t`: column `s` holds its `r = t - A_S(s)`
//! drawn voxels (every plane runs the same `d_S` recurrence from 0, so `A_S`
//! is one table).

use std::collections::VecDeque;

use super::{strides, Octant};

/// The axes `[P, S, R]`: weights descending (the lower index first on a tie).
pub fn axes(o: &Octant) -> [usize; 3] {
    let mut ax = [0usize, 1, 2];
    // Stable: equal weights keep index order.
    ax.sort_by(|&a, &b| o.weight[b].total_cmp(&o.weight[a]));
    ax
}

/// The increments of `d_S` and `d_P` (see the module doc's clamps).
pub fn ratios(o: &Octant) -> (f64, f64) {
    let [ap, a_s, ar] = axes(o);
    let (w_p, w_s, w_r) = (o.weight[ap], o.weight[a_s], o.weight[ar]);
    let (n_s, n_r) = (o.len(a_s), o.len(ar));
    // d_S += Δy/Δz = w_R / w_S, at least one column per column length.
    let ratio_s = if w_s > 0.0 { w_r / w_s } else { 0.0 };
    let ratio_s = ratio_s.max(1.0 / n_r as f64).min(1.0);
    // Step depth h = ratio_S w_S; d_P += h / w_P (= Δx/Δz unclamped).
    let h = ratio_s * w_s;
    let ratio_p = if w_p > 0.0 { h / w_p } else { 0.0 };
    let plane_steps = joined(ratio_s, n_s).last().copied().unwrap_or(0) + n_r;
    let ratio_p = ratio_p.max(1.0 / plane_steps as f64).min(1.0);
    (ratio_s, ratio_p)
}

/// `A_S(s)`: the step (counted from the plane's first) at which column `s`
/// joins `S`, by the `d_S` recurrence.
pub(super) fn joined(ratio_s: f64, n_s: u64) -> Vec<u64> {
    let mut out = Vec::with_capacity(n_s as usize);
    if n_s == 0 {
        return out;
    }
    out.push(0);
    let (mut d_s, mut t) = (0.0f64, 0u64);
    while (out.len() as u64) < n_s {
        t += 1;
        d_s += ratio_s;
        if d_s >= 1.0 {
            out.push(t);
            d_s -= 1.0;
        }
    }
    out
}

/// One voxel plane in `P`.
struct Plane {
    /// Linear index of the plane's far corner voxel.
    base: i64,
    /// `S[index]` is the column range `[head, tail)`.
    head: u64,
    tail: u64,
    /// Steps this plane has drawn.
    t: u64,
    /// The column accumulator `d_S[index]`.
    d_s: f64,
}

/// Walks box `o` of a `dims` grid in the DDA order.
pub fn walk(o: &Octant, dims: [u64; 3], f: &mut impl FnMut(u64)) {
    if o.is_empty() {
        return;
    }
    let st = strides(dims);
    let [ap, a_s, ar] = axes(o);
    let (n_p, n_s, n_r) = (o.len(ap), o.len(a_s), o.len(ar));
    let (step_p, step_s, step_r) = (
        o.near_stride(ap, st),
        o.near_stride(a_s, st),
        o.near_stride(ar, st),
    );
    let (ratio_s, ratio_p) = ratios(o);
    let a_s_tab = joined(ratio_s, n_s);
    // idx(p, s, r) = base(p) + s step_S + r step_R, with r = t - A_S(s):
    // col_off[s] = s step_S - A_S(s) step_R, so idx = base + t step_R + col_off[s].
    let col_off: Vec<i64> = (0..n_s)
        .map(|s| s as i64 * step_s - a_s_tab[s as usize] as i64 * step_r)
        .collect();
    let corner = o.far_corner(st);
    let new_plane = |p: u64| Plane {
        base: corner + p as i64 * step_p,
        head: 0,
        tail: 1,
        t: 0,
        d_s: 0.0,
    };
    let mut planes: VecDeque<Plane> = VecDeque::new();
    planes.push_back(new_plane(0));
    let mut next_p = 1u64;
    let mut d_p = 0.0f64;
    while !planes.is_empty() {
        for pl in planes.iter_mut() {
            // (1): the farthest undrawn voxel of every column in S[index].
            let row = pl.base + pl.t as i64 * step_r;
            for off in &col_off[pl.head as usize..pl.tail as usize] {
                f((row + off) as u64);
            }
            pl.t += 1;
            pl.d_s += ratio_s;
            if pl.d_s >= 1.0 && pl.tail < n_s {
                debug_assert_eq!(a_s_tab[pl.tail as usize], pl.t);
                pl.tail += 1;
                pl.d_s -= 1.0;
            }
            if pl.head < pl.tail && pl.t >= a_s_tab[pl.head as usize] + n_r {
                pl.head += 1;
            }
        }
        d_p += ratio_p;
        if d_p >= 1.0 && next_p < n_p {
            planes.push_back(new_plane(next_p));
            next_p += 1;
            d_p -= 1.0;
        }
        if planes.front().is_some_and(|pl| pl.head == n_s) {
            planes.pop_front();
        }
        // Guard: rounding can make the next plane due one step after the
        // last one finished; start it now rather than stop early.
        if planes.is_empty() && next_p < n_p {
            planes.push_back(new_plane(next_p));
            next_p += 1;
            d_p = 0.0;
        }
    }
}

/// `J_P(p)`: the outer-loop iteration at which plane `p` (counted from the
/// far side) makes its first step, by the same `d_P` recurrence, plane
/// removal and restart guard as [`walk`]. A plane is fully drawn after
/// `life = A_S(n_S - 1) + n_R` steps (columns finish one step apart at
/// most, because they join at least one step apart), so voxel `(p, s, r)`
/// is drawn in iteration `J_P(p) + A_S(s) + r`, and within one iteration
/// planes go in `p` order and columns in `s` order: the walk's sequence is
/// the voxels sorted by `(J_P(p) + A_S(s) + r, p, s)`.
pub(super) fn plane_starts(ratio_p: f64, n_p: u64, life: u64) -> Vec<u64> {
    let mut starts = Vec::with_capacity(n_p as usize);
    if n_p == 0 {
        return starts;
    }
    starts.push(0);
    // Start iterations of the planes in P, oldest first.
    let mut planes: VecDeque<u64> = VecDeque::from([0]);
    let mut next_p = 1u64;
    let mut d_p = 0.0f64;
    let mut g = 0u64;
    while !planes.is_empty() {
        // Iteration g: every plane steps; then the bookkeeping of `walk`.
        d_p += ratio_p;
        if d_p >= 1.0 && next_p < n_p {
            planes.push_back(g + 1);
            starts.push(g + 1);
            next_p += 1;
            d_p -= 1.0;
        }
        if planes.front().is_some_and(|&j| g + 1 - j >= life) {
            planes.pop_front();
        }
        if planes.is_empty() && next_p < n_p {
            planes.push_back(g + 1);
            starts.push(g + 1);
            next_p += 1;
            d_p = 0.0;
        }
        g += 1;
    }
    starts
}
