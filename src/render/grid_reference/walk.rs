//! The ray's path through the voxel cells: clipped to the volume box, then
//! walked cell by cell with the 3D DDA of Amanatides and Woo (1987).
//!
//! # Clipping
//!
//! In grid coordinates (sample `(i, j, k)` at integer `(i, j, k)`) the ray is
//! `G(t) = G0 + t dG` with `G0 = (o - origin) / spacing`, `dG = d / spacing`.
//! The field lives on the box `[0, n_a - 1]` on each axis; the slab test gives
//! `[t_in, t_out] = ∩_a [(0 - G0_a) / dG_a, (n_a - 1 - G0_a) / dG_a]`
//! (ordered), intersected with `t >= 0` (nothing behind the eye).
//!
//! # Walking
//!
//! The first cell is `floor(G(t_in))` per axis (`ceil - 1` when the ray runs
//! towards lower indices, so that a start on a cell face picks the cell the
//! ray enters), clamped to `[0, n_a - 2]`. On each axis the next face crossed
//! lies at `t_max_a = (face_a - G0_a) / dG_a` with `face_a = c_a + 1`
//! (`dG_a > 0`) or `c_a` (`dG_a < 0`); the cell is left at
//! `min_a t_max_a`, through the face of that axis, and the walk steps one
//! cell along it. `t_max` is recomputed from `G0` at every step rather than
//! accumulated, so there is no drift over long rays.

/// One stretch of the ray inside one cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellStretch {
    /// Lower corner of the cell (grid indices).
    pub cell: [u64; 3],
    /// Ray parameter where the stretch starts.
    pub t0: f64,
    /// Ray parameter where it ends.
    pub t1: f64,
    /// Local coordinates (in `[0, 1]^3` up to rounding) at `t0`.
    pub u0: [f64; 3],
    /// Change of the local coordinates per unit of `t` (`= dG`).
    pub du: [f64; 3],
}

/// `[t_in, t_out]` of the ray `G0 + t dG` in the box `[0, hi]`, `t >= 0`,
/// or `None` if it misses (or only grazes: `t_out <= t_in`).
pub fn clip(g0: [f64; 3], dg: [f64; 3], hi: [f64; 3]) -> Option<(f64, f64)> {
    let (mut t_in, mut t_out) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        if dg[a] == 0.0 {
            if g0[a] < 0.0 || g0[a] > hi[a] {
                return None;
            }
            continue;
        }
        let ta = (0.0 - g0[a]) / dg[a];
        let tb = (hi[a] - g0[a]) / dg[a];
        t_in = t_in.max(ta.min(tb));
        t_out = t_out.min(ta.max(tb));
    }
    (t_out > t_in).then_some((t_in, t_out))
}

/// Calls `visit` for every cell stretch of the ray `G0 + t dG` (grid
/// coordinates) inside a grid of `dims` samples, front to back, until it
/// returns `false`. Returns the number of cells visited.
pub fn walk(
    g0: [f64; 3],
    dg: [f64; 3],
    dims: [u64; 3],
    mut visit: impl FnMut(&CellStretch) -> bool,
) -> u64 {
    let hi = dims.map(|n| (n - 1) as f64);
    let Some((t_in, t_out)) = clip(g0, dg, hi) else {
        return 0;
    };
    let mut cell = [0u64; 3];
    for a in 0..3 {
        let g = g0[a] + t_in * dg[a];
        let c = if dg[a] < 0.0 {
            g.ceil() - 1.0
        } else {
            g.floor()
        };
        cell[a] = c.clamp(0.0, hi[a] - 1.0) as u64;
    }
    let mut t = t_in;
    let mut visited = 0;
    loop {
        // Next face per axis.
        let mut t_next = t_out;
        let mut axis = 3;
        for a in 0..3 {
            if dg[a] == 0.0 {
                continue;
            }
            let face = if dg[a] > 0.0 {
                cell[a] as f64 + 1.0
            } else {
                cell[a] as f64
            };
            let ta = (face - g0[a]) / dg[a];
            if ta < t_next {
                t_next = ta;
                axis = a;
            }
        }
        let t1 = t_next.max(t);
        if t1 > t {
            let u0 = std::array::from_fn(|a| g0[a] + t * dg[a] - cell[a] as f64);
            visited += 1;
            let s = CellStretch {
                cell,
                t0: t,
                t1,
                u0,
                du: dg,
            };
            if !visit(&s) {
                return visited;
            }
        }
        if axis == 3 || t1 >= t_out {
            return visited;
        }
        // Step across the face of `axis`.
        if dg[axis] > 0.0 {
            if cell[axis] + 2 >= dims[axis] {
                return visited;
            }
            cell[axis] += 1;
        } else {
            if cell[axis] == 0 {
                return visited;
            }
            cell[axis] -= 1;
        }
        t = t1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The stretches tile [t_in, t_out] without gaps, and each stretch's
        /// midpoint lies in its cell.
        #[test]
        fn stretches_tile_the_clipped_ray(
            g0 in proptest::array::uniform3(-5.0f64..12.0),
            dir in proptest::array::uniform3(-1.0f64..1.0),
        ) {
            let dims = [5u64, 7, 4];
            prop_assume!(dir.iter().map(|x| x * x).sum::<f64>() > 1e-3);
            let hi = dims.map(|n| (n - 1) as f64);
            let clipped = clip(g0, dir, hi);
            let mut prev: Option<f64> = None;
            let mut first = None;
            walk(g0, dir, dims, |s| {
                if first.is_none() { first = Some(s.t0); }
                if let Some(p) = prev { assert!((s.t0 - p).abs() <= 1e-9 * (1.0 + p.abs()), "gap {p} {}", s.t0); }
                prev = Some(s.t1);
                let tm = 0.5 * (s.t0 + s.t1);
                for a in 0..3 {
                    let g = g0[a] + tm * dir[a];
                    assert!(g >= s.cell[a] as f64 - 1e-9 && g <= s.cell[a] as f64 + 1.0 + 1e-9,
                        "axis {a}: {g} outside cell {:?}", s.cell);
                }
                true
            });
            match clipped {
                Some((a, b)) => {
                    prop_assert!((first.unwrap() - a).abs() < 1e-9);
                    prop_assert!((prev.unwrap() - b).abs() < 1e-9 * (1.0 + b.abs()));
                }
                None => prop_assert!(first.is_none()),
            }
        }
    }

    #[test]
    fn axis_aligned_ray_visits_each_cell_once() {
        let mut cells = Vec::new();
        walk([-1.0, 0.5, 0.5], [1.0, 0.0, 0.0], [4, 2, 2], |s| {
            cells.push(s.cell);
            true
        });
        assert_eq!(cells, vec![[0, 0, 0], [1, 0, 0], [2, 0, 0]]);
        let mut back = Vec::new();
        walk([3.0, 0.5, 0.5], [-1.0, 0.0, 0.0], [4, 2, 2], |s| {
            back.push(s.cell);
            true
        });
        assert_eq!(back, vec![[2, 0, 0], [1, 0, 0], [0, 0, 0]]);
    }
}
