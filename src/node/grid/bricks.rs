//! Subvolumes (bricks): cutting the whole into `d^3` bricks with a
//! one-voxel overlap, their screen rectangles, their visibility order for a
//! view, and their placement on `P` nodes.
//!
//! # Cuts
//!
//! Along an axis with `N` samples the cut points are
//! `c_i = round(i (N - 1) / d)`, `i = 0..=d`; brick `i` holds samples
//! `c_i ..= c_{i+1}`, so neighbours share the sample layer `c_{i+1}` (the
//! overlap trilinear interpolation needs: without it the cells between the
//! two bricks' samples would belong to neither and show as a seam).
//!
//! # Visibility order
//!
//! Rays move monotonically along every axis, away from the eye's coordinate
//! (orthographic: in the direction of `sign(forward_a)`). Along axis `a` let
//! `e_a` be the slab of the eye (`-1` before the first, `d` after the last
//! for a perspective eye outside; `∓∞` for orthographic views). A ray that
//! leaves brick `A` and later enters brick `B` has `|B_a - e_a| >= |A_a -
//! e_a|` on every axis, so sorting by `key = Σ_a |idx_a - e_a|` (ties by
//! brick id) puts every brick before the bricks behind it on any ray: a
//! visibility order for both projections (property-tested).

use crate::base::Rect;
use crate::data::{Volume, Voxels};
use crate::error::{Error, Result};
use crate::scene::{Projection, View};

/// One brick of the whole volume.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Brick {
    /// Index in `z`-major order: `i + d (j + d k)`.
    pub id: u32,
    /// Position in the brick grid.
    pub idx: [u32; 3],
    /// First sample (index of the whole).
    pub lo: [u64; 3],
    /// Samples per axis (last sample `lo + dims - 1`, shared with the next brick).
    pub dims: [u64; 3],
}

/// Cut points `c_0..=c_d` of an axis of `n` samples.
pub fn cuts(n: u64, d: u32) -> Vec<u64> {
    (0..=d as u64)
        .map(|i| ((i as f64 * (n - 1) as f64 / d as f64).round()) as u64)
        .collect()
}

/// The `d^3` bricks of a volume of `dims` samples (`z`-major order).
/// Fails when an axis has fewer than `d + 1` samples (a brick needs two
/// samples per axis to have a volume).
pub fn split(dims: [u64; 3], d: u32) -> Result<Vec<Brick>> {
    if d == 0 {
        return Err(Error::Invalid("--subvolumes must be >= 1".into()));
    }
    if let Some(a) = (0..3).find(|&a| dims[a] < d as u64 + 1) {
        return Err(Error::Invalid(format!(
            "--subvolumes {d}: axis {a} has only {} samples; each of the {d} bricks along it needs 2",
            dims[a]
        )));
    }
    let c: Vec<Vec<u64>> = (0..3).map(|a| cuts(dims[a], d)).collect();
    let mut out = Vec::with_capacity((d * d * d) as usize);
    for k in 0..d {
        for j in 0..d {
            for i in 0..d {
                let idx = [i, j, k];
                let lo: [u64; 3] = std::array::from_fn(|a| c[a][idx[a] as usize]);
                let dims: [u64; 3] = std::array::from_fn(|a| c[a][idx[a] as usize + 1] - lo[a] + 1);
                out.push(Brick {
                    id: i + d * (j + d * k),
                    idx,
                    lo,
                    dims,
                });
            }
        }
    }
    Ok(out)
}

/// The brick's samples as a volume of their own (world placement kept).
pub fn extract(whole: &Volume, b: &Brick) -> Volume {
    let [nx, ny, _] = whole.dims;
    fn cut<T: Copy>(data: &[T], nx: u64, ny: u64, b: &Brick) -> Vec<T> {
        let [bx, by, bz] = b.dims;
        let mut v = Vec::with_capacity((bx * by * bz) as usize);
        for k in 0..bz {
            for j in 0..by {
                let row = b.lo[0] + nx * ((b.lo[1] + j) + ny * (b.lo[2] + k));
                v.extend_from_slice(&data[row as usize..(row + bx) as usize]);
            }
        }
        v
    }
    let voxels = match &whole.voxels {
        Voxels::U8(d) => Voxels::U8(cut(d, nx, ny, b)),
        Voxels::U16(d) => Voxels::U16(cut(d, nx, ny, b)),
        Voxels::I16(d) => Voxels::I16(cut(d, nx, ny, b)),
        Voxels::F32(d) => Voxels::F32(cut(d, nx, ny, b)),
    };
    Volume {
        dims: b.dims,
        spacing: whole.spacing,
        origin: std::array::from_fn(|a| whole.origin[a] + b.lo[a] as f64 * whole.spacing[a]),
        field: whole.field.clone(),
        voxels,
    }
}

/// The pixels whose centres may see the brick: its 8 corners projected,
/// padded by one pixel, clipped to the screen. Perspective with a corner at
/// or behind the eye: the whole screen (a conservative bound).
pub fn screen_rect(view: &View, whole: &Volume, b: &Brick) -> Rect {
    let full = Rect {
        x0: 0,
        y0: 0,
        x1: view.width,
        y1: view.height,
    };
    let (mut x0, mut y0, mut x1, mut y1) = (
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    );
    for c in 0..8 {
        let g: [f64; 3] = std::array::from_fn(|a| {
            (b.lo[a] + if c >> a & 1 == 1 { b.dims[a] - 1 } else { 0 }) as f64
        });
        let p = whole.grid_to_world(g);
        let Some([x, y]) = view.camera_to_pixel(view.to_camera(p)) else {
            return full;
        };
        x0 = x0.min(x);
        y0 = y0.min(y);
        x1 = x1.max(x);
        y1 = y1.max(y);
    }
    // Pixel i's centre is i + 1/2: i in [x0 - 1/2, x1 - 1/2], padded by one.
    let lo = |v: f64, m: u32| ((v - 1.5).floor().max(0.0) as u64).min(m as u64) as u32;
    let hi = |v: f64, m: u32| ((v + 0.5).ceil().max(0.0) as u64 + 1).min(m as u64) as u32;
    let r = Rect {
        x0: lo(x0, view.width),
        y0: lo(y0, view.height),
        x1: hi(x1, view.width),
        y1: hi(y1, view.height),
    };
    Rect {
        x1: r.x1.max(r.x0),
        y1: r.y1.max(r.y0),
        ..r
    }
}

/// Per brick id, its rank in visibility order (0 = nearest the eye).
pub fn visibility_ranks(view: &View, whole: &Volume, d: u32, bricks: &[Brick]) -> Vec<u32> {
    let cut: Vec<Vec<u64>> = (0..3).map(|a| cuts(whole.dims[a], d)).collect();
    let eye_g = whole.world_to_grid(view.eye);
    let slab = |a: usize| -> f64 {
        match view.projection {
            Projection::Orthographic { .. } => {
                let f = view.forward[a];
                if f > 0.0 {
                    f64::NEG_INFINITY
                } else if f < 0.0 {
                    f64::INFINITY
                } else {
                    0.0
                }
            }
            Projection::Perspective { .. } => {
                let g = eye_g[a];
                let c = &cut[a];
                if g < c[0] as f64 {
                    -1.0
                } else if g > c[d as usize] as f64 {
                    d as f64
                } else {
                    // The slab holding g (the last when it is on the far face).
                    (0..d as usize)
                        .find(|&i| g <= c[i + 1] as f64)
                        .unwrap_or(d as usize - 1) as f64
                }
            }
        }
    };
    let e = [slab(0), slab(1), slab(2)];
    let key = |b: &Brick| -> f64 {
        (0..3)
            .map(|a| {
                if e[a].is_infinite() {
                    // Orthographic: ordered along the view direction.
                    if e[a] < 0.0 {
                        b.idx[a] as f64
                    } else {
                        (d - 1 - b.idx[a]) as f64
                    }
                } else if view.forward[a] == 0.0
                    && matches!(view.projection, Projection::Orthographic { .. })
                {
                    0.0
                } else {
                    (b.idx[a] as f64 - e[a]).abs()
                }
            })
            .sum()
    };
    let mut order: Vec<usize> = (0..bricks.len()).collect();
    order.sort_by(|&x, &y| {
        key(&bricks[x])
            .total_cmp(&key(&bricks[y]))
            .then(bricks[x].id.cmp(&bricks[y].id))
    });
    let mut rank = vec![0u32; bricks.len()];
    for (r, &i) in order.iter().enumerate() {
        rank[bricks[i].id as usize] = r as u32;
    }
    rank
}

/// How bricks are spread over nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum BrickPlacement {
    /// Brick `b` to node `b mod P` (the paper).
    RoundRobin,
    /// Longest processing time first: bricks by decreasing weight (voxels
    /// whose value the transfer function makes visible), each to the node
    /// with the least weight so far (ties: lower rank).
    Balanced,
}

/// Per node, its brick ids; `weight[b]` is brick `b`'s estimated work.
pub fn place(n_bricks: usize, nodes: usize, how: BrickPlacement, weight: &[u64]) -> Vec<Vec<u32>> {
    let mut out = vec![Vec::new(); nodes];
    match how {
        BrickPlacement::RoundRobin => {
            for b in 0..n_bricks {
                out[b % nodes].push(b as u32);
            }
        }
        BrickPlacement::Balanced => {
            let mut order: Vec<usize> = (0..n_bricks).collect();
            order.sort_by(|&a, &b| weight[b].cmp(&weight[a]).then(a.cmp(&b)));
            let mut load = vec![0u64; nodes];
            for b in order {
                let k = (0..nodes).min_by_key(|&k| (load[k], k)).unwrap_or(0);
                load[k] += weight[b];
                out[k].push(b as u32);
            }
            for v in &mut out {
                v.sort_unstable();
            }
        }
    }
    out
}
