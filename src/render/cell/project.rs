//! Phase 1 of cell projection: every vertex is transformed once per frame.
//!
//! The transform runs in f64 on camera-relative coordinates (`p - eye`) and
//! only then rounds to f32, so a mesh far from the origin loses no precision.
//!
//! - Orthographic: *screen space* `(X, Y, Z)`, `X`, `Y` in pixels (pixel
//!   centres at half-integers, `Y` down) and `Z` the depth along the view
//!   direction in world units. Rays are the lines `X, Y = const`.
//! - Perspective: the camera frame `(x right, y up, z forward)` relative to the
//!   eye, in world units; the ray of pixel `(X, Y)` is `τ d` with
//!   `d = ((X - W/2) p, (H/2 - Y) p, 1)`, `p` the pixel size at unit depth.

use rayon::prelude::*;

use crate::scene::{Projection, View};

/// Vertices of the mesh in the space the scan converter works in.
#[derive(Debug, Clone)]
pub struct ProjectedVertices {
    /// Orthographic or perspective.
    pub perspective: bool,
    /// Screen space (orthographic) or camera frame (perspective), f32.
    pub pos: Vec<[f32; 3]>,
    /// Perspective: continuous pixel coordinates, `[NaN, NaN]` for vertices
    /// at or behind the eye. Empty in orthographic views, where they are
    /// `pos`'s first two (read them with [`ProjectedVertices::pixel`]).
    pixel: Vec<[f32; 2]>,
    /// Normalised scalar per vertex.
    pub s: Vec<f32>,
    /// Image width and height.
    pub size: (u32, u32),
    /// Perspective: pixel size at unit depth.
    pub pixel_size: f32,
}

impl ProjectedVertices {
    /// Transforms `points` (world) for `view` and rounds the scalars to f32.
    pub fn new(view: &View, points: &[[f64; 3]], s_norm: &[f64]) -> ProjectedVertices {
        let perspective = matches!(view.projection, Projection::Perspective { .. });
        let (pos, pixel) = if perspective {
            points.par_iter().map(|&p| project_vertex(view, p)).unzip()
        } else {
            (
                points
                    .par_iter()
                    .map(|&p| project_vertex(view, p).0)
                    .collect(),
                Vec::new(),
            )
        };
        ProjectedVertices {
            perspective,
            pos,
            pixel,
            s: s_norm.iter().map(|&s| s as f32).collect(),
            size: (view.width, view.height),
            pixel_size: view.pixel_size as f32,
        }
    }

    /// Like [`ProjectedVertices::new`], on the calling thread only (the
    /// result is identical: every vertex is transformed independently).
    pub fn new_sequential(view: &View, points: &[[f64; 3]], s_norm: &[f64]) -> ProjectedVertices {
        let perspective = matches!(view.projection, Projection::Perspective { .. });
        let (pos, pixel) = if perspective {
            points.iter().map(|&p| project_vertex(view, p)).unzip()
        } else {
            (
                points.iter().map(|&p| project_vertex(view, p).0).collect(),
                Vec::new(),
            )
        };
        ProjectedVertices {
            perspective,
            pos,
            pixel,
            s: s_norm.iter().map(|&s| s as f32).collect(),
            size: (view.width, view.height),
            pixel_size: view.pixel_size as f32,
        }
    }

    /// Orthographic vertices given in screen space (`pos`: pixel `x`, `y`
    /// and depth), with scalars `s`, in a `size` image.
    pub fn screen(pos: Vec<[f32; 3]>, s: Vec<f32>, size: (u32, u32)) -> ProjectedVertices {
        ProjectedVertices {
            perspective: false,
            pos,
            pixel: Vec::new(),
            s,
            size,
            pixel_size: 1.0,
        }
    }

    /// Bytes the vertices hold.
    pub fn heap_bytes(&self) -> usize {
        self.pos.capacity() * 12 + self.pixel.capacity() * 8 + self.s.capacity() * 4
    }

    /// Continuous pixel coordinates of vertex `v`; `[NaN, NaN]` for a
    /// vertex at or behind the eye.
    #[inline(always)]
    pub fn pixel(&self, v: usize) -> [f32; 2] {
        if self.perspective {
            self.pixel[v]
        } else {
            let p = self.pos[v];
            [p[0], p[1]]
        }
    }

    /// The perspective rays of this image.
    pub fn rays(&self) -> PerspRays {
        PerspRays {
            half_w: self.size.0 as f32 * 0.5,
            half_h: self.size.1 as f32 * 0.5,
            pixel_size: self.pixel_size,
        }
    }
}

/// Perspective ray directions in the camera frame.
#[derive(Debug, Clone, Copy)]
pub struct PerspRays {
    half_w: f32,
    half_h: f32,
    pixel_size: f32,
}

impl PerspRays {
    /// Ray direction (not normalised, `z = 1`) of the pixel centre `(x, y)`.
    #[inline(always)]
    pub fn dir(&self, x: f32, y: f32) -> [f32; 3] {
        [
            (x - self.half_w) * self.pixel_size,
            (self.half_h - y) * self.pixel_size,
            1.0,
        ]
    }
}

/// One world point in the scan converter's space: `(position, pixel)` as
/// stored in [`ProjectedVertices`].
#[inline]
pub fn project_vertex(view: &View, p: [f64; 3]) -> ([f32; 3], [f32; 2]) {
    let perspective = matches!(view.projection, Projection::Perspective { .. });
    let c = view.to_camera(p);
    let px = view
        .camera_to_pixel(c)
        .map(|q| [q[0] as f32, q[1] as f32])
        .unwrap_or([f32::NAN; 2]);
    let pos = if perspective {
        c.map(|v| v as f32)
    } else {
        [px[0], px[1], c[2] as f32]
    };
    (pos, px)
}
