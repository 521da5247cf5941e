//! Camera of `scene.md`: orthographic or perspective, pixel centres at
//! `(i + 0.5, j + 0.5)` with `i` to the right and `j` downward.
//!
//! The camera frame is `right = normalize((target - eye) x up)`,
//! `up' = right x forward` (the given `up` re-orthogonalised) and
//! `forward = normalize(target - eye)`. All of it is f64: coordinates are made
//! camera-relative (`p - eye`) before anything is rounded to f32, so a mesh
//! offset by 1e6 renders as well as one at the origin.

/// Projection model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// Parallel rays; `height` is the world height of the view.
    Orthographic {
        /// World height covered by the image.
        height: f64,
    },
    /// Rays from the eye; `fov_y_deg` is the vertical field of view.
    Perspective {
        /// Vertical field of view in degrees, in (0, 180).
        fov_y_deg: f64,
    },
}

/// A validated camera plus the image size it is used with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position (world).
    pub eye: [f64; 3],
    /// Point looked at (world).
    pub target: [f64; 3],
    /// Approximate up direction.
    pub up: [f64; 3],
    /// Orthographic or perspective.
    pub projection: Projection,
}

/// The orthonormal camera frame and the pixel mapping, ready to use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Eye position (world, f64).
    pub eye: [f64; 3],
    /// Image-plane horizontal axis (unit).
    pub right: [f64; 3],
    /// Image-plane vertical axis (unit, points up on screen).
    pub up: [f64; 3],
    /// Viewing direction (unit).
    pub forward: [f64; 3],
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Projection.
    pub projection: Projection,
    /// Orthographic: world size of one pixel. Perspective: size of one pixel on
    /// the plane at unit distance in front of the eye (`2 tan(fov/2) / height`).
    pub pixel_size: f64,
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
pub(crate) fn scale(a: [f64; 3], k: f64) -> [f64; 3] {
    [a[0] * k, a[1] * k, a[2] * k]
}

impl Camera {
    /// Why this camera cannot be used, if it cannot: the name of the bad key
    /// and the reason.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let all = self.eye.iter().chain(&self.target).chain(&self.up);
        if all.clone().any(|v| !v.is_finite()) {
            return Err(("camera", "eye, target and up must be finite numbers".into()));
        }
        let f = sub(self.target, self.eye);
        let lf = norm(f);
        if lf == 0.0 {
            return Err((
                "camera.target",
                "eye and target are the same point: no view direction".into(),
            ));
        }
        let lu = norm(self.up);
        if lu == 0.0 {
            return Err(("camera.up", "up is the zero vector".into()));
        }
        let c = norm(cross(f, self.up)) / (lf * lu);
        if c < 1e-9 {
            return Err((
                "camera.up",
                "up is parallel to the view direction (target - eye)".into(),
            ));
        }
        match self.projection {
            Projection::Orthographic { height } if !(height > 0.0 && height.is_finite()) => Err((
                "camera.height",
                format!("orthographic height must be > 0, got {height}"),
            )),
            Projection::Perspective { fov_y_deg } if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) => {
                Err((
                    "camera.fov_y_deg",
                    format!("field of view must be in (0, 180) degrees, got {fov_y_deg}"),
                ))
            }
            _ => Ok(()),
        }
    }

    /// World height of an orthographic view; `None` for perspective.
    pub fn projection_height(&self) -> Option<f64> {
        match self.projection {
            Projection::Orthographic { height } => Some(height),
            Projection::Perspective { .. } => None,
        }
    }

    /// The camera frame for an image of `width` x `height` pixels.
    /// The camera must have passed [`Camera::check`].
    pub fn view(&self, width: u32, height: u32) -> View {
        let fwd = sub(self.target, self.eye);
        let forward = scale(fwd, 1.0 / norm(fwd));
        let r = cross(forward, self.up);
        let right = scale(r, 1.0 / norm(r));
        let up = cross(right, forward);
        let pixel_size = match self.projection {
            Projection::Orthographic { height: h } => h / height as f64,
            Projection::Perspective { fov_y_deg } => {
                2.0 * (fov_y_deg.to_radians() * 0.5).tan() / height as f64
            }
        };
        View {
            eye: self.eye,
            right,
            up,
            forward,
            width,
            height,
            projection: self.projection,
            pixel_size,
        }
    }
}

impl View {
    /// Camera-frame coordinates `(x right, y up, z forward)` of a world point,
    /// relative to the eye, in f64.
    pub fn to_camera(&self, p: [f64; 3]) -> [f64; 3] {
        let d = sub(p, self.eye);
        [dot(d, self.right), dot(d, self.up), dot(d, self.forward)]
    }

    /// Continuous pixel coordinates `(X, Y)` of a camera-frame point, pixel
    /// centres at half-integers. Perspective: `None` for points at or behind the eye.
    pub fn camera_to_pixel(&self, c: [f64; 3]) -> Option<[f64; 2]> {
        let (w, h) = (self.width as f64, self.height as f64);
        match self.projection {
            Projection::Orthographic { .. } => Some([
                w * 0.5 + c[0] / self.pixel_size,
                h * 0.5 - c[1] / self.pixel_size,
            ]),
            Projection::Perspective { .. } => {
                if c[2] <= 0.0 {
                    return None;
                }
                Some([
                    w * 0.5 + c[0] / (c[2] * self.pixel_size),
                    h * 0.5 - c[1] / (c[2] * self.pixel_size),
                ])
            }
        }
    }

    /// The ray through pixel centre `(i, j)`: origin and unit direction in
    /// world space; depth along it is the spec's depth.
    pub fn ray(&self, i: u32, j: u32) -> ([f64; 3], [f64; 3]) {
        let x = (i as f64 + 0.5) - self.width as f64 * 0.5;
        let y = self.height as f64 * 0.5 - (j as f64 + 0.5);
        match self.projection {
            Projection::Orthographic { .. } => {
                let (a, b) = (x * self.pixel_size, y * self.pixel_size);
                let o = [
                    self.eye[0] + a * self.right[0] + b * self.up[0],
                    self.eye[1] + a * self.right[1] + b * self.up[1],
                    self.eye[2] + a * self.right[2] + b * self.up[2],
                ];
                (o, self.forward)
            }
            Projection::Perspective { .. } => {
                let (a, b) = (x * self.pixel_size, y * self.pixel_size);
                let d = [
                    self.forward[0] + a * self.right[0] + b * self.up[0],
                    self.forward[1] + a * self.right[1] + b * self.up[1],
                    self.forward[2] + a * self.right[2] + b * self.up[2],
                ];
                (self.eye, scale(d, 1.0 / norm(d)))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aorta_view_a_axes() {
        let cam = Camera {
            eye: [-2.5, -200.0, -33.6],
            target: [-2.5, 0.0, -33.6],
            up: [-1.0, 0.0, 0.0],
            projection: Projection::Orthographic { height: 122.5 },
        };
        cam.check().unwrap();
        let v = cam.view(900, 300);
        assert!((v.right[2] - 1.0).abs() < 1e-12, "image right is +z");
        assert!((v.up[0] + 1.0).abs() < 1e-12);
        let (o, d) = v.ray(450, 150);
        assert!((d[1] - 1.0).abs() < 1e-12);
        assert!((o[2] - (-33.6 + 0.5 * 122.5 / 300.0)).abs() < 1e-9);
    }

    #[test]
    fn rejects_bad_cameras() {
        let mut cam = Camera {
            eye: [0.0; 3],
            target: [0.0; 3],
            up: [0.0, 0.0, 1.0],
            projection: Projection::Perspective { fov_y_deg: 30.0 },
        };
        assert_eq!(cam.check().unwrap_err().0, "camera.target");
        cam.target = [0.0, 0.0, 5.0];
        assert_eq!(cam.check().unwrap_err().0, "camera.up");
    }

    #[test]
    fn perspective_pixel_round_trip() {
        let cam = Camera {
            eye: [1.0, 2.0, 3.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
            projection: Projection::Perspective { fov_y_deg: 40.0 },
        };
        let v = cam.view(64, 48);
        let (o, d) = v.ray(10, 20);
        let p = [o[0] + 5.0 * d[0], o[1] + 5.0 * d[1], o[2] + 5.0 * d[2]];
        let px = v.camera_to_pixel(v.to_camera(p)).unwrap();
        assert!((px[0] - 10.5).abs() < 1e-9 && (px[1] - 20.5).abs() < 1e-9);
    }
}
