//! The generated head phantom of the grid tests (`tests/grid_skip.rs`,
//! `tests/shearwarp.rs`).
#![allow(dead_code)]

use std::path::Path;

use pvrsim::data::{Volume, Voxels};

/// A head phantom, u8, `n^3` voxels of 1 mm centred on the origin: air 0,
/// a skin shell (value 70) between radii 0.44 n and 0.47 n, fat/CSF (25)
/// inside it, and a "brain" (value 210, opaque under the TF) whose surface
/// is folded, radius 0.30 n (1 + 0.06 sin 5θ cos 4φ). Edges are smooth over
/// about `blur` voxels (tanh), like a scanner's partial-volume blur.
pub fn head_phantom(n: u64, blur: f64) -> Volume {
    let c = (n as f64 - 1.0) / 2.0;
    let mut v = Vec::with_capacity((n * n * n) as usize);
    let step = |x: f64| 0.5 * (1.0 + (x / blur).tanh());
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let (x, y, z) = (i as f64 - c, j as f64 - c, k as f64 - c);
                let r = (x * x + y * y + z * z).sqrt();
                let th = z.atan2((x * x + y * y).sqrt());
                let ph = y.atan2(x);
                let nf = n as f64;
                let brain = 0.30 * nf * (1.0 + 0.06 * (5.0 * th).sin() * (4.0 * ph).cos());
                let inside_head = step(0.47 * nf - r);
                let inside_skin = step(0.44 * nf - r);
                let inside_brain = step(brain - r);
                let s = inside_head * (70.0 * (1.0 - inside_skin) + 25.0 * inside_skin)
                    + inside_brain * (210.0 - 25.0);
                v.push(s.round().clamp(0.0, 255.0) as u8);
            }
        }
    }
    Volume::new(
        Path::new("head-phantom"),
        [n; 3],
        [1.0; 3],
        [-c; 3],
        "s",
        Voxels::U8(v),
    )
    .unwrap()
}
