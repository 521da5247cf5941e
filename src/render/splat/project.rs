//! Voxel index to footprint centre, the per-voxel step of the projection.
//!
//! - [`IndexSplit`]: the linear index `idx = i + nx (j + ny k)` back to
//!   `(i, j, k)` without 64-bit divisions (two f64 reciprocal
//!   multiplications and a one-step correction; exact for `idx < 2^52`,
//!   which the 64-bit voxel count of any grid that fits in memory is).
//! - [`OrthoCentres`]: in a parallel projection the pixel centre of voxel
//!   `(i, j, k)` is affine in the index,
//!   `X = X_0 + i a_x + j b_x + k c_x` (and `Y` alike), with
//!   `X_0 = w/2 + (o - e)·r / p`, `a = h_x r_x / p` ... (`o` the grid
//!   origin, `e` the eye, `r` the camera's right vector, `p` the pixel
//!   size, `h` the spacing; `Y` with the up vector and the opposite sign):
//!   three multiply-adds in f64 per voxel instead of the world point, the
//!   camera frame and the pixel map of [`super::footprint::FootprintModel::project`]
//!   (which it equals up to f64 rounding; tested).

use crate::data::Volume;
use crate::scene::camera::{Projection, View};

/// `idx -> (i, j, k)` for a grid of `dims`.
#[derive(Debug, Clone, Copy)]
pub struct IndexSplit {
    nx: u64,
    ny: u64,
    inv_nx: f64,
    inv_ny: f64,
}

impl IndexSplit {
    /// The split of grid `dims` (each >= 1).
    pub fn new(dims: [u64; 3]) -> IndexSplit {
        let (nx, ny) = (dims[0].max(1), dims[1].max(1));
        IndexSplit {
            nx,
            ny,
            inv_nx: 1.0 / nx as f64,
            inv_ny: 1.0 / ny as f64,
        }
    }

    /// `n / d` from the rounded reciprocal: the f64 quotient is within one
    /// of the true one for `n < 2^52`, so one correction each way.
    #[inline(always)]
    fn div(n: u64, d: u64, inv: f64) -> (u64, u64) {
        let mut q = (n as f64 * inv) as u64;
        if q * d > n {
            q -= 1;
        } else if (q + 1) * d <= n {
            q += 1;
        }
        (q, n - q * d)
    }

    /// `(i, j, k)` of linear index `idx`.
    #[inline(always)]
    pub fn split(&self, idx: u64) -> [u64; 3] {
        let (jk, i) = Self::div(idx, self.nx, self.inv_nx);
        let (k, j) = Self::div(jk, self.ny, self.inv_ny);
        [i, j, k]
    }
}

/// Pixel centres of voxels under a parallel projection (module doc).
#[derive(Debug, Clone, Copy)]
pub struct OrthoCentres {
    x0: [f64; 2],
    /// Per index step along grid axis `a`: `(dX, dY)`.
    step: [[f64; 2]; 3],
}

impl OrthoCentres {
    /// The map of `view` for `vol`'s grid; `None` for perspective views.
    pub fn new(view: &View, vol: &Volume) -> Option<OrthoCentres> {
        let Projection::Orthographic { .. } = view.projection else {
            return None;
        };
        let p = view.pixel_size;
        let d: [f64; 3] = std::array::from_fn(|a| vol.origin[a] - view.eye[a]);
        let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
        Some(OrthoCentres {
            x0: [
                view.width as f64 * 0.5 + dot(d, view.right) / p,
                view.height as f64 * 0.5 - dot(d, view.up) / p,
            ],
            step: std::array::from_fn(|a| {
                [
                    vol.spacing[a] * view.right[a] / p,
                    -vol.spacing[a] * view.up[a] / p,
                ]
            }),
        })
    }

    /// The pixel centre `(X, Y)` of voxel `(i, j, k)`.
    #[inline(always)]
    pub fn centre(&self, g: [u64; 3]) -> [f32; 2] {
        let [a, b, c] = self.step;
        let (i, j, k) = (g[0] as f64, g[1] as f64, g[2] as f64);
        [
            (self.x0[0] + (i * a[0] + j * b[0] + k * c[0])) as f32,
            (self.x0[1] + (i * a[1] + j * b[1] + k * c[1])) as f32,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::splat::footprint::FootprintModel;
    use proptest::prelude::*;

    proptest! {
        /// The split inverts `i + nx (j + ny k)`, also past 2^32.
        #[test]
        fn split_inverts_the_linear_index(
            nx in 1u64..5000, ny in 1u64..5000, i in 0u64..5000, j in 0u64..5000,
            k in 0u64..200_000,
        ) {
            let (i, j) = (i % nx, j % ny);
            let s = IndexSplit::new([nx, ny, 1]);
            prop_assert_eq!(s.split(i + nx * (j + ny * k)), [i, j, k]);
        }
    }

    /// The affine centres equal the footprint model's projection of the
    /// voxel's world point (to f32 rounding), for a tilted orthographic
    /// view of an anisotropic, offset grid.
    #[test]
    fn ortho_centres_match_the_projection() {
        use crate::data::Voxels;
        use crate::scene::camera::Camera;
        use crate::scene::{DataSpec, ImageSpec, Scene, TransferFunction};
        use std::path::{Path, PathBuf};
        let n = 24u64;
        let vol = Volume::new(
            Path::new("v"),
            [n, n + 3, n - 5],
            [0.7, 1.3, 0.9],
            [-3.0, 2.0, 5.5],
            "s",
            Voxels::U8(vec![7; (n * (n + 3) * (n - 5)) as usize]),
        )
        .unwrap();
        let scene = Scene {
            data: DataSpec {
                path: PathBuf::from("v"),
                field: "s".into(),
                range: Some([0.0, 255.0]),
            },
            camera: Camera {
                eye: [40.0, -25.0, 50.0],
                target: [5.0, 17.0, 14.0],
                up: [0.1, 1.0, 0.2],
                projection: Projection::Orthographic { height: 37.0 },
            },
            image: ImageSpec {
                width: 97,
                height: 61,
                background: [0.0; 3],
            },
            transfer: TransferFunction::from_rows(
                &[[0.0, 1.0, 1.0, 1.0, 0.5], [1.0, 1.0, 1.0, 1.0, 0.5]],
                1.0,
            ),
        };
        let view = scene.view();
        let model = FootprintModel::new(&view, vol.spacing, 0.6, 1.0, 3.0);
        let oc = OrthoCentres::new(&view, &vol).expect("orthographic");
        let split = IndexSplit::new(vol.dims);
        for g in [[0, 0, 0], [23, 0, 7], [5, 17, 18], [23, 26, 18]] {
            let w = vol.grid_to_world(g.map(|v| v as f64));
            let f = model.project(w).expect("in front");
            let c = oc.centre(g);
            assert!(
                (c[0] - f.x).abs() < 1e-4 && (c[1] - f.y).abs() < 1e-4,
                "{g:?}: {c:?} vs ({}, {})",
                f.x,
                f.y
            );
            let idx = g[0] + vol.dims[0] * (g[1] + vol.dims[1] * g[2]);
            assert_eq!(split.split(idx), g);
        }
    }
}
