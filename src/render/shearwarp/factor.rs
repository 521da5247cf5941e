//! The shear-warp factorisation of an orthographic view (Lacroute and
//! Levoy 1994, section 3).
//!
//! In grid coordinates `g = (p - origin) / spacing` a ray of unit world
//! direction `f` advances `dG = f / spacing` per world unit. The
//! **principal axis** `c` is the one with the largest `|dG_c|`: slices
//! perpendicular to it are crossed most densely, so one sample per voxel
//! slice never steps more than one voxel along the other axes. The axes are
//! renamed `(i, j, k)` with `k = c` (`c = x`: `(y, z, x)`, `c = y`:
//! `(z, x, y)`, `c = z`: `(x, y, z)`, the paper's standard object
//! coordinates).
//!
//! **Shear**: along a ray, `i` and `j` move by the shear coefficients
//! `s_i = dG_i / dG_k`, `s_j = dG_j / dG_k` per slice. In the *sheared
//! object space* the rays are parallel to `k`: the intermediate-image pixel
//! `(u, v)` meets slice `k` at
//!
//! ```text
//!   i = u + s_i k - t_i,   j = v + s_j k - t_j
//! ```
//!
//! with the translations `t_i = max(0, s_i (n_k - 1))`, `t_j` likewise,
//! chosen so that every slice lands at `u, v >= 0`. The offset
//! `s_i k - t_i` is the same for every pixel of a slice, so its bilinear
//! weights are too.
//!
//! **Warp**: the final pixel `(x, y)` (centre `+ 1/2`) casts the ray from
//! `o(x, y)` on the eye plane; with `G0 = grid(o)`, its intermediate pixel is
//! `u = t_i + G0_i - s_i G0_k` (`v` likewise): affine in `(x, y)`.
//!
//! The ray's world length per slice is `δ = 1 / |dG_k|`: the opacity of
//! every sample is corrected for it.

use glam::{DMat2, DVec2, DVec3};

use crate::data::Volume;
use crate::scene::View;

/// The principal axis of a grid-space view direction (largest `|component|`,
/// the lowest axis on ties) and the sign of that component (`true`: the
/// ray moves towards increasing `k`, so slice 0 is in front).
pub fn principal_axis(dg: [f64; 3]) -> (usize, bool) {
    let mut c = 0;
    for a in 1..3 {
        if dg[a].abs() > dg[c].abs() {
            c = a;
        }
    }
    (c, dg[c] > 0.0)
}

/// The object axes `(i, j, k)` for principal axis `c`.
pub fn axes(c: usize) -> [usize; 3] {
    match c {
        0 => [1, 2, 0],
        1 => [2, 0, 1],
        _ => [0, 1, 2],
    }
}

/// The factorisation of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Factor {
    /// The principal axis (`k`), 0 = x.
    pub principal: usize,
    /// The object axes `(i, j, k)` as volume axes.
    pub axes: [usize; 3],
    /// Voxels along `i`, `j`, `k`.
    pub n: [usize; 3],
    /// True when slice 0 is the front one (`dG_k > 0`).
    pub front_is_zero: bool,
    /// Shear coefficients `(s_i, s_j)`.
    pub shear: [f64; 2],
    /// Translations `(t_i, t_j)`.
    pub trans: [f64; 2],
    /// Intermediate image width and height.
    pub size: [usize; 2],
    /// World length of a ray between two slices.
    pub delta: f64,
    /// The warp: intermediate `(u, v) = warp_origin + warp_matrix (x, y)`
    /// for final pixel centre `(x + 1/2, y + 1/2)` at `(x, y)`.
    pub warp_origin: DVec2,
    /// Columns: `d(u, v)/dx`, `d(u, v)/dy`.
    pub warp_matrix: DMat2,
}

impl Factor {
    /// Factors an orthographic `view` of `vol` (the caller has refused
    /// perspective).
    pub fn new(view: &View, vol: &Volume) -> Factor {
        let h = DVec3::from_array(vol.spacing);
        let dg = DVec3::from_array(view.forward) / h;
        let (c, front_is_zero) = principal_axis(dg.to_array());
        let ax = axes(c);
        let n = ax.map(|a| vol.dims[a] as usize);
        let d = dg.to_array();
        let shear = [d[ax[0]] / d[ax[2]], d[ax[1]] / d[ax[2]]];
        let nk1 = (n[2] - 1) as f64;
        let trans = shear.map(|s| (s * nk1).max(0.0));
        let size = [0, 1].map(|a| ((n[a] - 1) as f64 + shear[a].abs() * nk1).floor() as usize + 2);
        // Grid coordinates of the eye-plane point of pixel centre (x, y).
        let origin = DVec3::from_array(vol.origin);
        let (w, hh) = (view.width as f64, view.height as f64);
        let ps = view.pixel_size;
        let right = DVec3::from_array(view.right);
        let up = DVec3::from_array(view.up);
        let g0 = |x: f64, y: f64| {
            let a = (x + 0.5 - 0.5 * w) * ps;
            let b = (0.5 * hh - (y + 0.5)) * ps;
            ((DVec3::from_array(view.eye) + a * right + b * up - origin) / h).to_array()
        };
        let uv = |g: [f64; 3]| {
            DVec2::new(
                trans[0] + g[ax[0]] - shear[0] * g[ax[2]],
                trans[1] + g[ax[1]] - shear[1] * g[ax[2]],
            )
        };
        let o = uv(g0(0.0, 0.0));
        let dx = uv(g0(1.0, 0.0)) - o;
        let dy = uv(g0(0.0, 1.0)) - o;
        Factor {
            principal: c,
            axes: ax,
            n,
            front_is_zero,
            shear,
            trans,
            size,
            delta: 1.0 / d[c].abs(),
            warp_origin: o,
            warp_matrix: DMat2::from_cols(dx, dy),
        }
    }

    /// The offset `(s_i k - t_i, s_j k - t_j)` of slice `k`: intermediate
    /// pixel `(u, v)` samples the slice at `(u, v) + offset`.
    pub fn slice_offset(&self, k: usize) -> [f64; 2] {
        let k = k as f64;
        [
            self.shear[0] * k - self.trans[0],
            self.shear[1] * k - self.trans[1],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn principal_axis_all_six_signs() {
        for c in 0..3 {
            for sign in [1.0, -1.0] {
                let mut d = [0.3, -0.2, 0.25];
                d[c] = sign * 0.9;
                assert_eq!(principal_axis(d), (c, sign > 0.0));
            }
        }
    }
}
