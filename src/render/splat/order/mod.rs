//! Back-to-front voxel visit orders for splatting a regular grid.
//!
//! Three families (issue 11, `splatting-dda-order.txt`):
//!
//! - [`axis`]: Westover's axis-aligned slices, perpendicular to the grid axis
//!   most parallel to the view, far to near;
//! - [`dda`]: the paper's view-aligned order built like a DDA line walk
//!   (Fig. 6: voxel planes `P`, columns `S[plane]`, accumulators `d_S`, `d_P`);
//! - [`sort`]: a full depth sort, as a comparison sort (quicksort) and as an
//!   O(N) counting sort of quantised depths.
//!
//! Every order calls a visitor with each voxel's 64-bit linear index
//! (`i + nx (j + ny k)`), farthest first.
//!
//! # Geometry
//!
//! Orderings work in grid-index space. Orthographic: the depth of voxel
//! `(i, j, k)` is `const + w · (i, j, k)` with `w_a = spacing_a · forward_a`.
//! Perspective: the depth is the distance from the eye to the voxel centre.
//!
//! # What "back to front" guarantees
//!
//! For cube voxels, a voxel `v` can hide `u` only through a chain of face
//! neighbours, each farther than the last (a ray leaves one cube through the
//! face it shares with the next). So it is enough (and necessary) that every
//! voxel comes after each of its *farther face-neighbours*:
//!
//! - orthographic: the neighbour `v + e_a` is farther iff `w_a > 0`
//!   (`w_a = 0`: neither is farther, the face is seen edge-on);
//! - perspective: `v + e_a` is farther iff the eye lies on `v`'s side of
//!   their shared face, i.e. `eye_a < v_a + 1/2` in grid coordinates.
//!
//! All three orders guarantee this exactly (tests in `tests.rs`), also for
//! perspective, through the **octant split** ([`octants`]): the grid is cut
//! at the voxel faces nearest the eye's grid coordinates into up to 8 boxes;
//! inside each, moving away from the eye is the same direction on every axis,
//! so a fixed-direction order is exact there; boxes are visited low half
//! before high half on every axis, which is what the face neighbours across
//! a cut need (the low one is always the farther one). Within a box the DDA
//! uses the direction from the eye to the box centre, so in perspective it
//! is a view-aligned order only approximately (depth is radial).

pub mod axis;
pub mod dda;
pub mod mask;
pub mod scatter;
pub mod sort;
pub mod sparse;

#[cfg(test)]
mod tests;

use std::fmt;

/// How depth varies over the grid (grid-index space).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OrderView {
    /// Parallel projection: `depth(i) = const + sum_a w[a] * i_a`,
    /// `w[a] = spacing[a] * forward[a]`.
    Orthographic {
        /// Depth increment per index step along each axis.
        w: [f64; 3],
    },
    /// Perspective: depth is the distance from `eye` to the voxel centre.
    Perspective {
        /// The eye in continuous grid coordinates (sample `(i,j,k)` at `(i,j,k)`).
        eye: [f64; 3],
        /// World spacing per axis (for distances and the DDA's weights).
        spacing: [f64; 3],
    },
}

impl OrderView {
    /// The view of an orthographic camera looking along `forward` (world)
    /// at a grid with `spacing`.
    pub fn orthographic(forward: [f64; 3], spacing: [f64; 3]) -> OrderView {
        OrderView::Orthographic {
            w: std::array::from_fn(|a| forward[a] * spacing[a]),
        }
    }

    /// Squared world distance (perspective) from the eye to voxel centre
    /// `g`, or the orthographic depth `w · g` (both grow away from the eye).
    #[inline]
    pub fn depth_key(&self, g: [f64; 3]) -> f64 {
        match *self {
            OrderView::Orthographic { w } => w[0] * g[0] + w[1] * g[1] + w[2] * g[2],
            OrderView::Perspective { eye, spacing } => (0..3)
                .map(|a| {
                    let d = (g[a] - eye[a]) * spacing[a];
                    d * d
                })
                .sum(),
        }
    }
}

/// Which back-to-front order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Order {
    /// Westover's axis-aligned slices.
    Axis,
    /// The paper's DDA view-aligned order.
    Dda,
    /// Full depth sort by comparison (`slice::sort_unstable_by_key`,
    /// std's pattern-defeating quicksort).
    Quicksort,
    /// Full depth sort by an O(N) counting sort of quantised depths.
    Radix,
}

impl Order {
    /// Every order, in the bench's column order.
    pub const ALL: [Order; 4] = [Order::Axis, Order::Dda, Order::Quicksort, Order::Radix];

    /// Name as used on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Order::Axis => "axis",
            Order::Dda => "dda",
            Order::Quicksort => "quicksort",
            Order::Radix => "radix",
        }
    }
}

impl fmt::Display for Order {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One box of the octant split: voxels `lo[a] .. hi[a]` (exclusive) on each
/// axis, walked far to near. `far_high[a]`: the far side is the high index.
/// `weight[a] >= 0`: how fast depth grows per index step towards the far
/// side (orthographic: `|w_a|`; perspective: from the eye to the box centre).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Octant {
    /// First voxel index per axis.
    pub lo: [u64; 3],
    /// One past the last voxel index per axis.
    pub hi: [u64; 3],
    /// The far side of the box is at `hi - 1` (else at `lo`).
    pub far_high: [bool; 3],
    /// Non-negative depth growth per index step towards the far side.
    pub weight: [f64; 3],
}

impl Octant {
    /// Voxels along axis `a`.
    #[inline]
    pub fn len(&self, a: usize) -> u64 {
        self.hi[a] - self.lo[a]
    }

    /// True when the box holds no voxel.
    pub fn is_empty(&self) -> bool {
        (0..3).any(|a| self.hi[a] <= self.lo[a])
    }

    /// Grid index along axis `a` of the `t`-th slab counted from the far side.
    #[inline]
    pub fn far_index(&self, a: usize, t: u64) -> u64 {
        if self.far_high[a] {
            self.hi[a] - 1 - t
        } else {
            self.lo[a] + t
        }
    }

    /// Linear-index step (signed) for one slab towards the eye along `a`.
    #[inline]
    pub fn near_stride(&self, a: usize, strides: [i64; 3]) -> i64 {
        if self.far_high[a] {
            -strides[a]
        } else {
            strides[a]
        }
    }

    /// Linear index of the box's farthest corner voxel.
    #[inline]
    pub fn far_corner(&self, strides: [i64; 3]) -> i64 {
        (0..3)
            .map(|a| self.far_index(a, 0) as i64 * strides[a])
            .sum()
    }
}

/// Linear-index strides `(1, nx, nx ny)`.
#[inline]
pub fn strides(dims: [u64; 3]) -> [i64; 3] {
    [1, dims[0] as i64, (dims[0] * dims[1]) as i64]
}

/// The octant split of a `dims` grid for `view`, in a back-to-front-safe
/// visiting order (see the module doc). Orthographic: one box, the whole grid.
/// Perspective: the cut on axis `a` is `c_a = clamp(floor(eye_a + 1/2), 0, n_a)`
/// (voxels `< c_a` have their upper face at or below the eye, voxels `>= c_a`
/// their lower face at or above it... except voxel `c_a` itself, which holds
/// the eye and is the nearest of the high half); empty boxes are dropped.
/// Boxes go in increasing bit mask (bit `a` set = high half on axis `a`), a
/// linear extension of "low before high on every axis".
pub fn octants(dims: [u64; 3], view: &OrderView) -> Vec<Octant> {
    match *view {
        OrderView::Orthographic { w } => vec![Octant {
            lo: [0; 3],
            hi: dims,
            far_high: std::array::from_fn(|a| w[a] > 0.0),
            weight: std::array::from_fn(|a| w[a].abs()),
        }],
        OrderView::Perspective { eye, spacing } => {
            let cut: [u64; 3] = std::array::from_fn(|a| {
                let c = (eye[a] + 0.5).floor();
                if c <= 0.0 {
                    0
                } else if c >= dims[a] as f64 {
                    dims[a]
                } else {
                    c as u64
                }
            });
            let mut out = Vec::with_capacity(8);
            for mask in 0..8u32 {
                let high = |a: usize| mask >> a & 1 == 1;
                let lo: [u64; 3] = std::array::from_fn(|a| if high(a) { cut[a] } else { 0 });
                let hi: [u64; 3] = std::array::from_fn(|a| if high(a) { dims[a] } else { cut[a] });
                let weight = std::array::from_fn(|a| {
                    let centre = (lo[a] as f64 + hi[a] as f64 - 1.0) * 0.5;
                    ((centre - eye[a]) * spacing[a]).abs()
                });
                let o = Octant {
                    lo,
                    hi,
                    far_high: std::array::from_fn(high),
                    weight,
                };
                if !o.is_empty() {
                    out.push(o);
                }
            }
            out
        }
    }
}

/// Visits every voxel of a `dims` grid in `order`, back to front.
pub fn visit(order: Order, dims: [u64; 3], view: &OrderView, f: impl FnMut(u64)) {
    visit_kept(order, dims, view, |_| true, f)
}

/// Visits the voxels for which `keep(idx)` holds, back to front. The axis
/// and DDA orders test `keep` as they walk (the paper's step (1)); the sorts
/// test it before sorting, so only kept voxels are sorted.
pub fn visit_kept(
    order: Order,
    dims: [u64; 3],
    view: &OrderView,
    keep: impl Fn(u64) -> bool,
    f: impl FnMut(u64),
) {
    visit_with(
        order,
        dims,
        view,
        keep,
        &mut sort::SortScratch::default(),
        f,
    )
}

/// [`visit_kept`] with the sorts' buffers kept by the caller (reused
/// across frames).
pub fn visit_with(
    order: Order,
    dims: [u64; 3],
    view: &OrderView,
    keep: impl Fn(u64) -> bool,
    scratch: &mut sort::SortScratch,
    mut f: impl FnMut(u64),
) {
    let boxes = octants(dims, view);
    let mut g = |idx: u64| {
        if keep(idx) {
            f(idx)
        }
    };
    match order {
        Order::Axis => boxes.iter().for_each(|o| axis::walk(o, dims, &mut g)),
        Order::Dda => boxes.iter().for_each(|o| dda::walk(o, dims, &mut g)),
        Order::Quicksort | Order::Radix => {
            sort::sorted(order == Order::Radix, &boxes, dims, view, &keep, scratch);
            scratch.out.iter().for_each(|&i| f(i));
        }
    }
}

/// The whole order as a vector of linear indices.
pub fn collect(order: Order, dims: [u64; 3], view: &OrderView) -> Vec<u64> {
    let n = dims.iter().product::<u64>() as usize;
    let mut out = Vec::with_capacity(n);
    visit(order, dims, view, |i| out.push(i));
    out
}

/// What [`collect_kept_map`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct KeptStats {
    /// Line masks built (one volume pass each).
    pub masks: usize,
    /// Wall ms of building them (the transparency pre-pass).
    pub prepass_ms: f64,
}

/// The kept voxels (`keep(idx)`) in `order`, back to front, into `out`
/// (cleared first) with their payloads (`class(idx)`, which must be `Some`
/// exactly where `keep` holds; `keep` is the cheap test run on every voxel):
/// [`collect_kept_map`] without a map. Returns the number of masks built.
pub fn collect_kept<T: Copy + Send + Sync + Default>(
    order: Order,
    dims: [u64; 3],
    view: &OrderView,
    keep: &(impl Fn(u64) -> bool + Sync),
    class: &(impl Fn(u64) -> Option<T> + Sync),
    scratch: &mut sort::SortScratch,
    out: &mut Vec<(u64, T)>,
) -> usize {
    out.clear();
    collect_kept_map(order, dims, view, keep, class, &|i, t| (i, t), scratch, out).masks
}

/// The kept voxels (`keep(idx)`) in `order`, back to front, each mapped by
/// `emit(idx, class(idx))`, appended to `out` (`class` must be `Some`
/// exactly where `keep` holds; `keep` is the cheap test run on every
/// voxel), through the transparency pre-pass: the axis and DDA orders build
/// the line masks of [`mask`] (one pass over the volume each, in parallel)
/// and walk only the kept voxels ([`sparse`], in parallel), emitting
/// exactly the sequence of [`visit_kept`]; the sorts test each voxel as in
/// [`visit_with`] and read the payloads in sorted order (mapped in
/// parallel).
#[allow(clippy::too_many_arguments)]
pub fn collect_kept_map<T: Copy + Send + Sync, S: Send>(
    order: Order,
    dims: [u64; 3],
    view: &OrderView,
    keep: &(impl Fn(u64) -> bool + Sync),
    class: &(impl Fn(u64) -> Option<T> + Sync),
    emit: &(impl Fn(u64, T) -> S + Sync),
    scratch: &mut sort::SortScratch,
    out: &mut Vec<S>,
) -> KeptStats {
    use rayon::prelude::*;
    let boxes = octants(dims, view);
    let mut masks = mask::Masks::new(dims, keep, class);
    match order {
        Order::Axis => boxes
            .iter()
            .for_each(|o| sparse::axis_sparse(o, dims, &mut masks, emit, out)),
        Order::Dda => boxes
            .iter()
            .for_each(|o| sparse::dda_sparse(o, dims, &mut masks, emit, out)),
        Order::Quicksort | Order::Radix => {
            sort::sorted(order == Order::Radix, &boxes, dims, view, keep, scratch);
            let mut mapped = Vec::new();
            scratch
                .out
                .par_iter()
                .map(|&i| {
                    let t = class(i).expect("class(idx) must be Some exactly where keep(idx)");
                    emit(i, t)
                })
                .collect_into_vec(&mut mapped);
            out.append(&mut mapped);
        }
    }
    KeptStats {
        masks: masks.built(),
        prepass_ms: masks.build_ms(),
    }
}
