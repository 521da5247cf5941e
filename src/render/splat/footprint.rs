//! EWA footprints (Zwicker, Pfister, van Baar, Gross 2001).
//!
//! Each voxel `k` carries a 3-D Gaussian reconstruction kernel
//! `r_k(u) = G_V(u - u_k)`, normalised (`∫ r_k = 1`), with object-space
//! variance `V = diag((σ h_x)², (σ h_y)², (σ h_z)²)` (`h` the spacing, `σ`
//! in voxels; `σ = 0.6` keeps the ripple of `Σ_k V_cell r_k` under 0.2 %).
//! The extinction field is `tau(u) ≈ Σ_k tau_k V_cell r_k(u)` with
//! `V_cell = h_x h_y h_z`, so a constant field stays constant.
//!
//! **Projection.** With `W` the world-to-camera rotation (rows right, up,
//! forward) and `J` the Jacobian of camera → ray space `(X, Y, L)` (pixel
//! coordinates and distance along the ray) at the voxel centre,
//! orthographic `J = diag(1/p, -1/p, 1)` (`p` the pixel size) and
//! perspective (camera point `t`, `l = |t|`, `p` the pixel size at unit
//! distance)
//!
//! ```text
//!     | 1/(t2 p)     0        -t0/(t2² p) |
//! J = |   0       -1/(t2 p)    t1/(t2² p) |
//!     | t0/l        t1/l        t2/l      |
//! ```
//!
//! the ray integral of `r_k` is `|det J| G_V̂(x - x_k)` with
//! `V̂ = (J W V Wᵀ Jᵀ)_{2x2} + V_h`, where `V_h = I` (pixels²) is the
//! screen-space low-pass filter of EWA (it widens footprints smaller than a
//! pixel and changes nothing of their integral).
//!
//! **Opacity (scene contract).** Along the ray through pixel `x` the voxel
//! adds the optical depth `tau_k l_k(x)` with
//! `l_k(x) = V_cell |det J| G_V̂(x - x_k)`, the voxel's effective extent
//! along that ray; its integral over the screen is the voxel's volume
//! (cross-section × extent), so the footprint integral is exactly the
//! extinction over the voxel's extent. The splat's alpha is
//! `alpha_k(x) = 1 - exp(-tau_k l_k(x))`, its premultiplied colour
//! `c_k alpha_k(x)`. For an axis-aligned view of cube voxels the centre
//! value is `l_k(x_k) = h / (2π σ²)` before the low-pass, the issue's
//! `alpha_voxel = 1 - exp(-tau(s) l)` with `l` the voxel's (Gaussian) extent.
//!
//! The Gaussian is cut at `k_cut` standard deviations (Mahalanobis) and
//! renormalised by `1 / (1 - exp(-k_cut²/2))` so that the integral stays exact.

use glam::{DMat3, DVec3};

use crate::scene::camera::{Projection, View};

/// A projected footprint: centre, conic, peak extent, bounding half-sizes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    /// Centre in continuous pixel coordinates.
    pub x: f32,
    /// Centre, vertical (downward).
    pub y: f32,
    /// Conic `Q = V̂⁻¹` as `(Q00, Q01, Q11)`, pre-halved: the exponent is
    /// `q0 dx² + 2 q1 dx dy + q2 dy²`.
    pub q: [f32; 3],
    /// `l_k` at the centre (world length), renormalised for the cut.
    pub l0: f32,
    /// Half-width of the bounding box, pixels.
    pub rx: f32,
    /// Half-height of the bounding box, pixels.
    pub ry: f32,
}

/// The per-view constants of the footprint computation.
#[derive(Debug, Clone)]
pub struct FootprintModel {
    view: View,
    /// `W V Wᵀ`: the kernel's covariance in camera coordinates.
    v_cam: DMat3,
    /// `V_cell`.
    v_cell: f64,
    /// Low-pass variance (pixels²).
    low_pass: f64,
    /// Cut radius in standard deviations.
    k_cut: f64,
    /// Orthographic: the footprint shape shared by every voxel.
    ortho: Option<Footprint>,
}

impl FootprintModel {
    /// Constants for `view`, grid `spacing`, kernel `sigma` (voxels),
    /// low-pass variance `low_pass` (pixels²), cut `k_cut` (std devs).
    pub fn new(view: &View, spacing: [f64; 3], sigma: f64, low_pass: f64, k_cut: f64) -> Self {
        let w = DMat3::from_cols(
            DVec3::from(view.right),
            DVec3::from(view.up),
            DVec3::from(view.forward),
        )
        .transpose();
        let v = DMat3::from_diagonal(DVec3::from(spacing.map(|h| (sigma * h).powi(2))));
        let v_cam = w * v * w.transpose();
        let mut m = FootprintModel {
            view: *view,
            v_cam,
            v_cell: spacing.iter().product(),
            low_pass,
            k_cut,
            ortho: None,
        };
        if let Projection::Orthographic { .. } = view.projection {
            let p = view.pixel_size;
            let j = DMat3::from_diagonal(DVec3::new(1.0 / p, -1.0 / p, 1.0));
            m.ortho = Some(m.shape(j, 0.0, 0.0));
        }
        m
    }

    /// The footprint shape for Jacobian `j` (rows as in the module doc).
    fn shape(&self, j: DMat3, x: f64, y: f64) -> Footprint {
        let vp = j * self.v_cam * j.transpose();
        // V̂: the top-left 2x2 of V' plus the low-pass filter.
        let (a, b, c) = (
            vp.x_axis.x + self.low_pass,
            vp.y_axis.x,
            vp.y_axis.y + self.low_pass,
        );
        let det = a * c - b * b;
        let det_j = j.determinant().abs();
        let mass = 1.0 - (-0.5 * self.k_cut * self.k_cut).exp();
        let l0 = self.v_cell * det_j / (2.0 * std::f64::consts::PI * det.sqrt()) / mass;
        Footprint {
            x: x as f32,
            y: y as f32,
            q: [
                (0.5 * c / det) as f32,
                (-0.5 * b / det) as f32,
                (0.5 * a / det) as f32,
            ],
            l0: l0 as f32,
            rx: (self.k_cut * a.sqrt()) as f32,
            ry: (self.k_cut * c.sqrt()) as f32,
        }
    }

    /// Orthographic views: the footprint shape every voxel shares (centre
    /// at 0); perspective: `None`.
    pub fn orthographic_shape(&self) -> Option<Footprint> {
        self.ortho
    }

    /// The cut as a bound on the exponent: `k_cut² / 2`.
    pub fn exponent_cut(&self) -> f32 {
        (0.5 * self.k_cut * self.k_cut) as f32
    }

    /// The footprint of a voxel centred at world point `p`, or `None` when
    /// it is at or behind the eye (perspective).
    #[inline]
    pub fn project(&self, p: [f64; 3]) -> Option<Footprint> {
        let t = self.view.to_camera(p);
        let px = self.view.camera_to_pixel(t)?;
        if let Some(mut f) = self.ortho {
            f.x = px[0] as f32;
            f.y = px[1] as f32;
            return Some(f);
        }
        let (t0, t1, t2) = (t[0], t[1], t[2]);
        let p = self.view.pixel_size;
        let l = (t0 * t0 + t1 * t1 + t2 * t2).sqrt();
        // Rows of J (module doc), as columns of its transpose.
        let jt = DMat3::from_cols(
            DVec3::new(1.0 / (t2 * p), 0.0, -t0 / (t2 * t2 * p)),
            DVec3::new(0.0, -1.0 / (t2 * p), t1 / (t2 * t2 * p)),
            DVec3::new(t0 / l, t1 / l, t2 / l),
        );
        Some(self.shape(jt.transpose(), px[0], px[1]))
    }
}
