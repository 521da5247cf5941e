//! The cameras of a series' orbit (`pvrsim cluster --frames N --turn DEG`,
//! mesh and grid scenes alike: [`orbit`]).

/// The cameras of `--frames N --turn DEG`: the scene's camera, then the
/// eye turned `k DEG` degrees about the target around the camera's up
/// vector (`eye' = target + R_up(k DEG) (eye - target)`).
pub fn orbit(cam: &super::Camera, frames: u32, turn_deg: f64) -> Vec<super::Camera> {
    use glam::{DQuat, DVec3};
    let target = DVec3::from(cam.target);
    let axis = DVec3::from(cam.up).normalize_or_zero();
    (0..frames.max(1))
        .map(|k| {
            let q = DQuat::from_axis_angle(axis, (k as f64 * turn_deg).to_radians());
            let mut c = *cam;
            if k > 0 && axis != DVec3::ZERO {
                c.eye = (target + q * (DVec3::from(cam.eye) - target)).to_array();
            }
            c
        })
        .collect()
}

/// The frames of `cams` (images of `width` x `height`) that crop the
/// data: those where a point of `points` projects outside the image (or,
/// in perspective, at or behind the eye). The 8 corners of the points'
/// bounding box decide first: when every frame holds them, it holds every
/// point.
pub fn cropping_frames(
    cams: &[super::Camera],
    width: u32,
    height: u32,
    points: &[[f64; 3]],
) -> Vec<usize> {
    use rayon::prelude::*;
    if points.is_empty() {
        return Vec::new();
    }
    let (lo, hi) = points.iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1]), lo[2].min(p[2])],
                [hi[0].max(p[0]), hi[1].max(p[1]), hi[2].max(p[2])],
            )
        },
    );
    let corners = box_corners(lo, hi);
    let outside = |v: &super::View, p: &[f64; 3]| match v.camera_to_pixel(v.to_camera(*p)) {
        Some([x, y]) => !(0.0..=width as f64).contains(&x) || !(0.0..=height as f64).contains(&y),
        None => true,
    };
    cams.iter()
        .enumerate()
        .filter(|(_, c)| {
            let v = c.view(width, height);
            corners.iter().any(|p| outside(&v, p)) && points.par_iter().any(|p| outside(&v, p))
        })
        .map(|(k, _)| k)
        .collect()
}

/// `cam` with its extent widened so that the data's bounding sphere about
/// the orbit's centre (the target; radius: the farthest point of `points`)
/// stays in an image of `width` x `height` however the eye turns about the
/// target (`--fit-orbit`): turning moves no point of that sphere, so it is
/// held from every side. Orthographic: the view's height; perspective: the
/// field of view. The eye, target and up stay; an extent that already
/// holds the sphere is kept. `None` when the eye is inside the sphere (no
/// field of view holds it).
pub fn fit_orbit(
    cam: &super::Camera,
    width: u32,
    height: u32,
    points: &[[f64; 3]],
) -> Option<super::Camera> {
    use super::Projection;
    use glam::DVec3;
    if points.is_empty() {
        return Some(*cam);
    }
    let target = DVec3::from(cam.target);
    let reach = points
        .iter()
        .map(|p| DVec3::from(*p).distance(target))
        .fold(0.0, f64::max);
    // Both image axes must hold `reach`: the shorter one decides.
    let aspect = width as f64 / height as f64;
    let mut out = *cam;
    match cam.projection {
        Projection::Orthographic { height: h } => {
            let need = 2.0 * reach / aspect.min(1.0) * 1.02;
            out.projection = Projection::Orthographic {
                height: h.max(need),
            };
        }
        Projection::Perspective { fov_y_deg } => {
            let d = DVec3::from(cam.eye).distance(target);
            if d <= reach {
                return None;
            }
            // The half angle that holds a sphere of radius `reach` at the
            // target seen from distance d, on the shorter axis.
            let half = (reach / d).asin() * 1.02;
            let half_y = (half.tan() / aspect.min(1.0)).atan();
            let need = (2.0 * half_y).to_degrees();
            if need >= 179.0 {
                return None;
            }
            out.projection = Projection::Perspective {
                fov_y_deg: fov_y_deg.max(need),
            };
        }
    }
    Some(out)
}

/// The eight corners of the axis-aligned box `lo..hi`.
pub fn box_corners(lo: [f64; 3], hi: [f64; 3]) -> Vec<[f64; 3]> {
    (0..8)
        .map(|k| {
            [
                if k & 1 == 0 { lo[0] } else { hi[0] },
                if k & 2 == 0 { lo[1] } else { hi[1] },
                if k & 4 == 0 { lo[2] } else { hi[2] },
            ]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Camera, Projection};

    /// A long bar along x seen from -y, its height fitted to one side.
    fn long_bar() -> (Camera, Vec<[f64; 3]>) {
        let cam = Camera {
            eye: [0.0, -10.0, 0.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
            projection: Projection::Orthographic { height: 2.2 },
        };
        let pts = vec![[-1.0, -0.1, -0.1], [1.0, 0.1, 0.1], [0.0, 0.0, 0.0]];
        (cam, pts)
    }

    #[test]
    fn an_orbit_that_turns_a_long_side_past_a_square_image_crops_it() {
        let (mut cam, pts) = long_bar();
        // A thin image: 2.2 high, 0.55 wide; the bar (2 long) is cropped
        // from the front, not from the side (0.2 deep).
        cam.projection = Projection::Orthographic { height: 2.2 };
        let cams = orbit(&cam, 4, 90.0);
        assert_eq!(cropping_frames(&cams, 25, 100, &pts), vec![0, 2]);
        // Square and 2.2 high: nothing is cropped at any angle.
        assert!(cropping_frames(&cams, 100, 100, &pts).is_empty());
    }

    #[test]
    fn fitting_the_orbit_holds_the_bounding_sphere_at_every_angle() {
        let (cam, pts) = long_bar();
        let fitted = fit_orbit(&cam, 25, 100, &pts).unwrap();
        let cams = orbit(&fitted, 36, 10.0);
        assert!(cropping_frames(&cams, 25, 100, &pts).is_empty());
        assert_eq!(
            (fitted.eye, fitted.target, fitted.up),
            (cam.eye, cam.target, cam.up)
        );
        // Perspective too.
        let mut p = cam;
        p.projection = Projection::Perspective { fov_y_deg: 5.0 };
        assert!(!cropping_frames(&orbit(&p, 36, 10.0), 25, 100, &pts).is_empty());
        let fitted = fit_orbit(&p, 25, 100, &pts).unwrap();
        assert!(cropping_frames(&orbit(&fitted, 36, 10.0), 25, 100, &pts).is_empty());
        // An eye inside the sphere: no field of view holds it.
        p.eye = [0.0, -0.5, 0.0];
        assert!(fit_orbit(&p, 25, 100, &pts).is_none());
    }
}
