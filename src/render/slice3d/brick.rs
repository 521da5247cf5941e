//! Rendering one **brick** of a larger volume (sort-last parallel rendering,
//! `parallel-texture-vr-rle.txt`): the brick's samples lie on the **whole
//! volume's** slice planes, and each sample belongs to exactly one brick.
//!
//! # Same planes everywhere
//!
//! [`BrickFrame::planes`] are the planes of the whole volume
//! ([`Planes::new`] over the whole box), and the ray's parameters are
//! computed in the whole volume's grid coordinates `G0 + t dG`, exactly as
//! the single-node renderer does; only the clip box changes. A brick with
//! its own planes would place slices at other depths: the bricks' sample
//! sets would interleave or collide at the faces (ghosts, seams).
//!
//! # One owner per sample
//!
//! Bricks overlap by one voxel (they share the face layer of samples that
//! trilinear interpolation needs on both sides) and their boxes meet at that
//! face. The brick clips the ray to its box `[lo, hi]` with the same
//! expression `t = (face - G0_a) / dG_a` its neighbour uses for the shared
//! face, so both get the same `t` bit for bit; a brick takes the slices with
//! depth in `[z_in, z_out)`, closed at `z_out` only when `t_out` is the
//! whole volume's exit (so the far face of the volume is kept, as in the
//! single-node render). Every slice sample of the whole is then drawn by
//! exactly one brick.

use super::planes::{Planes, RaySamples};
use crate::base::Rect;
use crate::scene::View;

/// Where a brick sits in the whole volume, and the whole's slice planes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrickFrame {
    /// The whole volume's slice planes (identical in every brick).
    pub planes: Planes,
    /// The whole volume's origin (world).
    pub origin: [f64; 3],
    /// The whole volume's spacing (world).
    pub spacing: [f64; 3],
    /// The whole volume's samples per axis.
    pub whole_dims: [u64; 3],
    /// The brick's first sample, as an index of the whole.
    pub lo: [u64; 3],
    /// The brick's samples per axis (its last sample is `lo + dims - 1`).
    pub dims: [u64; 3],
    /// Pixels to render; the others are left untouched.
    pub rect: Rect,
}

/// The pixels a renderer draws and returns for `brick` in a `w` x `h`
/// frame, as `(x0, y0, width, height)`: the brick's rectangle, or the
/// whole frame without a brick.
pub fn draw_area(brick: Option<&BrickFrame>, w: u32, h: u32) -> (u32, u32, u32, u32) {
    brick.map_or((0, 0, w, h), |b| {
        (b.rect.x0, b.rect.y0, b.rect.width(), b.rect.height())
    })
}

/// `[t_in, t_out]` of `G0 + t dG` inside the box `[lo, hi]` (global grid
/// coordinates), `t >= 0`; each face's crossing is `(face - G0_a) / dG_a`,
/// the same expression in the bricks on both sides of a face.
fn clip_box(g0: [f64; 3], dg: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> Option<(f64, f64)> {
    let (mut t_in, mut t_out) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        if dg[a] == 0.0 {
            if !(lo[a]..=hi[a]).contains(&g0[a]) {
                return None;
            }
            continue;
        }
        let (x, y) = ((lo[a] - g0[a]) / dg[a], (hi[a] - g0[a]) / dg[a]);
        t_in = t_in.max(x.min(y));
        t_out = t_out.min(x.max(y));
    }
    (t_out > t_in).then_some((t_in, t_out))
}

/// The samples of pixel `(i, j)` owned by the brick, in the brick's own
/// grid coordinates, or `None` if there are none.
pub fn ray_samples(
    view: &View,
    b: &BrickFrame,
    unit_distance: f64,
    i: u32,
    j: u32,
) -> Option<RaySamples> {
    let (o, d) = view.ray(i, j);
    let f = view.forward;
    let cos = d[0] * f[0] + d[1] * f[1] + d[2] * f[2];
    let z_o = view.to_camera(o)[2];
    let g0: [f64; 3] = std::array::from_fn(|a| (o[a] - b.origin[a]) / b.spacing[a]);
    let dg: [f64; 3] = std::array::from_fn(|a| d[a] / b.spacing[a]);
    let lo = b.lo.map(|x| x as f64);
    let hi: [f64; 3] = std::array::from_fn(|a| (b.lo[a] + b.dims[a] - 1) as f64);
    let (t_in, t_out) = clip_box(g0, dg, lo, hi)?;
    let whole_hi = b.whole_dims.map(|n| (n - 1) as f64);
    let closed = clip_box(g0, dg, [0.0; 3], whole_hi).is_some_and(|(_, t)| t == t_out);
    let p = &b.planes;
    let (z_in, z_out) = (z_o + t_in * cos, z_o + t_out * cos);
    let k0 = ((z_in - p.z_start) / p.delta - 0.5).ceil().max(0.0);
    let x1 = (z_out - p.z_start) / p.delta - 0.5;
    let k1 = if closed { x1.floor() } else { x1.ceil() - 1.0 };
    let k1 = k1.min(p.n as f64 - 1.0);
    if k1 < k0 {
        return None;
    }
    let t0 = (p.z_start + 0.5 * p.delta - z_o) / cos;
    let dt = p.delta / cos;
    Some(RaySamples {
        start: std::array::from_fn(|a| (g0[a] - lo[a] + t0 * dg[a]) as f32),
        step: std::array::from_fn(|a| (dt * dg[a]) as f32),
        k_first: k0 as u64,
        k_last: k1 as u64,
        k_ud: (dt / unit_distance) as f32,
        // The partial steps at the box's entry and exit are used only by
        // pre-integrated classification, which brick rendering does not
        // offer (the cluster slices with post-classification).
        head: 0.0,
        tail: 0.0,
    })
}
