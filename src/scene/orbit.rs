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
