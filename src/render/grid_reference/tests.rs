//! Analytic tests of the grid reference: constant slab (closed form, both
//! projections), linear ramp (closed form), opacity 1, a trilinear field
//! with kinks against brute-force midpoint integration, thread independence.

use std::path::Path;
use std::sync::Arc;

use super::*;
use crate::data::{Volume, Voxels};
use crate::scene::Scene;

/// A scene over a volume, `camera` and `transfer` as TOML bodies.
pub(crate) fn scene(camera: &str, transfer: &str, size: u32, range: Option<[f64; 2]>) -> Scene {
    let range = range
        .map(|r| format!("range = [{}, {}]", r[0], r[1]))
        .unwrap_or_default();
    Scene::parse(
        &format!(
            "[data]\npath = \"v.nrrd\"\nfield = \"s\"\n{range}\n[camera]\n{camera}\n\
             [image]\nwidth = {size}\nheight = {size}\nbackground = [0.2, 0.1, 0.0]\n\
             [transfer]\n{transfer}\n"
        ),
        Path::new("t.toml"),
    )
    .unwrap()
}

pub(crate) fn volume(
    dims: [u64; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
    f: impl Fn([f64; 3]) -> f32,
) -> Volume {
    let mut v = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = [
                    origin[0] + i as f64 * spacing[0],
                    origin[1] + j as f64 * spacing[1],
                    origin[2] + k as f64 * spacing[2],
                ];
                v.push(f(p));
            }
        }
    }
    Volume::new(Path::new("gen"), dims, spacing, origin, "s", Voxels::F32(v)).unwrap()
}

const ORTHO_Z: &str = "eye = [0.1, 0.05, -10]\ntarget = [0.1, 0.05, 0]\nup = [0, 1, 0]\nprojection = \"orthographic\"\nheight = 1";

#[test]
fn constant_slab_is_closed_form() {
    // Box z in [-1.5, 1.5] (thickness 3), opacity 0.3 per unit 2, colour (0.8, 0.4, 0.2).
    let vol = volume([4, 4, 7], [1.0, 1.0, 0.5], [-1.5, -1.5, -1.5], |_| 5.0);
    let sc = scene(
        ORTHO_Z,
        "unit_distance = 2\npoints = [[0, 0.8, 0.4, 0.2, 0.3], [1, 0.8, 0.4, 0.2, 0.3]]",
        4,
        Some([0.0, 10.0]),
    );
    let inp = VolumeInput::new(sc, Arc::new(vol)).unwrap();
    let (img, st) = render(&inp, &Default::default());
    let t = 0.7f64.powf(3.0 / 2.0);
    for p in &img.pixels {
        assert!((p[3] as f64 - (1.0 - t)).abs() < 1e-6, "alpha {}", p[3]);
        assert!((p[0] as f64 - (0.8 * (1.0 - t) + 0.2 * t)).abs() < 1e-6);
        assert!((p[1] as f64 - (0.4 * (1.0 - t) + 0.1 * t)).abs() < 1e-6);
    }
    assert_eq!(st.quadrature_depth_limited, 0);
    assert_eq!(st.rays_hit, 16);
}

#[test]
fn constant_slab_in_perspective_follows_the_path_length() {
    // Eye on the z axis; each pixel's ray crosses z in [-1.5, 1.5] over a
    // length 3 / cos(theta), theta its angle to the axis (all rays leave
    // through the back face: the box is wide).
    let vol = volume([3, 3, 4], [20.0, 20.0, 1.0], [-20.0, -20.0, -1.5], |_| 1.0);
    let sc = scene(
        "eye = [0, 0, -10]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nprojection = \"perspective\"\nfov_y_deg = 40",
        "unit_distance = 1\npoints = [[0, 1, 1, 1, 0.2], [1, 1, 1, 1, 0.2]]",
        8,
        Some([0.0, 2.0]),
    );
    let inp = VolumeInput::new(sc.clone(), Arc::new(vol)).unwrap();
    let (img, _) = render(&inp, &Default::default());
    let view = sc.camera.view(8, 8);
    for j in 0..8 {
        for i in 0..8 {
            let (_, d) = view.ray(i, j);
            let len = 3.0 / d[2];
            let t = 0.8f64.powf(len);
            let a = img.get(i, j)[3] as f64;
            assert!(
                (a - (1.0 - t)).abs() < 1e-6,
                "({i},{j}) alpha {a} vs {}",
                1.0 - t
            );
        }
    }
}

#[test]
fn linear_ramp_is_closed_form() {
    // s = (z + 1.5) / 3 along the ray (z from -1.5 to 1.5: s from 0 to 1),
    // opacity o(s) = a s per unit distance 1, white: tau(s) = -ln(1 - a s),
    // optical depth 3 ∫_0^1 -ln(1 - a s) ds = 3 [((1 - a) ln(1 - a) + a) / a].
    let a = 0.6f64;
    let vol = volume([3, 3, 7], [1.0, 1.0, 0.5], [-1.0, -1.0, -1.5], |p| {
        ((p[2] + 1.5) / 3.0) as f32
    });
    let sc = scene(
        ORTHO_Z,
        &format!("unit_distance = 1\npoints = [[0, 1, 1, 1, 0], [1, 1, 1, 1, {a}]]"),
        2,
        Some([0.0, 1.0]),
    );
    let inp = VolumeInput::new(sc, Arc::new(vol)).unwrap();
    let (img, _) = render(&inp, &Default::default());
    let depth = 3.0 * (((1.0 - a) * (1.0 - a).ln() + a) / a);
    let t = (-depth).exp();
    for p in &img.pixels {
        assert!(
            (p[3] as f64 - (1.0 - t)).abs() < 1e-6,
            "{} vs {}",
            p[3],
            1.0 - t
        );
        assert!((p[0] as f64 - ((1.0 - t) + 0.2 * t)).abs() < 1e-6);
    }
}

#[test]
fn opacity_one_gives_the_colour() {
    let vol = volume([3, 3, 3], [1.0; 3], [-1.0; 3], |_| 0.0);
    let sc = scene(
        ORTHO_Z,
        "unit_distance = 1\npoints = [[0, 0.3, 0.6, 0.9, 1.0], [1, 0.3, 0.6, 0.9, 1.0]]",
        2,
        Some([0.0, 1.0]),
    );
    let inp = VolumeInput::new(sc, Arc::new(vol)).unwrap();
    let (img, _) = render(&inp, &Default::default());
    for p in &img.pixels {
        // T = (1e-6)^2 over 2 units.
        assert!(
            (p[0] - 0.3).abs() < 1e-6 && (p[2] - 0.9).abs() < 1e-6,
            "{p:?}"
        );
        assert!((p[3] - 1.0).abs() < 1e-6);
    }
}

/// Brute force: midpoint rule with `n` steps through `Volume::trilinear`
/// over the ray's stretch inside the box (clipped here by its own slab
/// test, in world coordinates, so that no step straddles the boundary).
fn brute(inp: &VolumeInput, o: [f64; 3], d: [f64; 3], n: usize) -> ([f64; 3], f64) {
    let tf = &inp.scene.transfer;
    let (lo, hi) = inp.volume.bounds();
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        let (x, y) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
        t0 = t0.max(x.min(y));
        t1 = t1.min(x.max(y));
    }
    if t1 <= t0 {
        return ([0.0; 3], 1.0);
    }
    let h = (t1 - t0) / n as f64;
    let (mut c, mut t) = ([0.0; 3], 1.0f64);
    for k in 0..n {
        let tm = t0 + (k as f64 + 0.5) * h;
        let p = [o[0] + tm * d[0], o[1] + tm * d[1], o[2] + tm * d[2]];
        let Some(s) = inp.volume.trilinear(p) else {
            continue;
        };
        let (rgb, _) = tf.eval(inp.normalise(s));
        let tau = tf.extinction(inp.normalise(s));
        let a = 1.0 - (-tau * h).exp();
        for ch in 0..3 {
            c[ch] += t * a * rgb[ch];
        }
        t *= 1.0 - a;
    }
    (c, t)
}

#[test]
fn oblique_rays_through_a_kinked_field_match_brute_force() {
    // A genuinely trilinear (non-linear) field, a TF with kinks inside the
    // range, oblique perspective rays: the cubic, its kink crossings and
    // the DDA must all be right to agree with a 200,000-step midpoint sum.
    let vol = volume([5, 4, 6], [0.7, 1.1, 0.5], [-1.4, -1.6, -1.2], |p| {
        (p[0] * p[1] * p[2] + 0.5 * p[0] - p[1] * p[1] + 2.0) as f32
    });
    let sc = scene(
        "eye = [4, 3, -6]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nprojection = \"perspective\"\nfov_y_deg = 30",
        "unit_distance = 0.5\npoints = [[0, 0, 0, 1, 0], [0.3, 0, 1, 0, 0.6], [0.45, 1, 1, 0, 0.05], [0.7, 1, 0, 0, 0.9], [1, 1, 1, 1, 0.3]]",
        5,
        None,
    );
    let inp = VolumeInput::new(sc.clone(), Arc::new(vol)).unwrap();
    let (img, st) = render(&inp, &Default::default());
    assert!(st.cells_visited > 0);
    let view = sc.camera.view(5, 5);
    let mut worst = 0.0f64;
    for j in 0..5 {
        for i in 0..5 {
            let (o, d) = view.ray(i, j);
            let (c, t) = brute(&inp, o, d, 200_000);
            let p = img.get(i, j);
            worst = worst.max((p[3] as f64 - (1.0 - t)).abs());
            for ch in 0..3 {
                let bg = sc.image.background[ch];
                worst = worst.max((p[ch] as f64 - (c[ch] + t * bg)).abs());
            }
        }
    }
    // Midpoint error with h = 1e-4 on this field is ~1e-7.
    assert!(worst < 2e-6, "worst {worst}");
}

#[test]
fn image_does_not_depend_on_threads() {
    let vol = volume([6, 5, 4], [1.0; 3], [-2.5, -2.0, -1.5], |p| {
        (p[0].sin() + p[1] * p[2]) as f32
    });
    let sc = scene(
        "eye = [3, -2, -6]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nprojection = \"perspective\"\nfov_y_deg = 50",
        "unit_distance = 1\npoints = [[0, 1, 0, 0, 0.1], [1, 0, 0, 1, 0.7]]",
        9,
        None,
    );
    let inp = VolumeInput::new(sc, Arc::new(vol)).unwrap();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let (a, _) = one.install(|| render(&inp, &Default::default()));
    let (b, _) = render(&inp, &Default::default());
    assert_eq!(a, b);
}
