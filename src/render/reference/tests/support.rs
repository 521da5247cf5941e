//! Shared helpers of the reference renderer's tests: scenes and cameras,
//! meshes built in code (Kuhn grids), ray–box chords, the independent 1D
//! emission–absorption integral and the pixel check.

use std::sync::Arc;

use crate::data::lattice::kuhn_tets;
use crate::data::{Field, TetMesh};
use crate::render::reference::*;
use crate::scene::{Camera, DataSpec, ImageSpec, Projection, Scene, TransferFunction};

pub(super) fn tf(points: &[[f64; 5]], ud: f64) -> TransferFunction {
    TransferFunction::from_rows(points, ud)
}

/// A transfer function with kinks and varying colour.
pub(super) fn tf_ramp() -> TransferFunction {
    tf(
        &[
            [0.0, 0.1, 0.2, 0.9, 0.0],
            [0.3, 0.2, 0.8, 0.3, 0.6],
            [0.55, 0.9, 0.9, 0.1, 0.1],
            [1.0, 1.0, 0.1, 0.1, 0.35],
        ],
        0.8,
    )
}

pub(super) fn scene(
    camera: Camera,
    w: u32,
    h: u32,
    bg: [f64; 3],
    transfer: TransferFunction,
) -> Scene {
    Scene {
        data: DataSpec {
            path: "test".into(),
            field: "s".into(),
            range: Some([0.0, 1.0]),
        },
        camera,
        image: ImageSpec {
            width: w,
            height: h,
            background: bg,
        },
        transfer,
    }
}

pub(super) fn ortho(eye: [f64; 3], target: [f64; 3], up: [f64; 3], height: f64) -> Camera {
    Camera {
        eye,
        target,
        up,
        projection: Projection::Orthographic { height },
    }
}

pub(super) fn persp(eye: [f64; 3], target: [f64; 3], up: [f64; 3], fov: f64) -> Camera {
    Camera {
        eye,
        target,
        up,
        projection: Projection::Perspective { fov_y_deg: fov },
    }
}

/// Renders `mesh` with the per-vertex scalar `s(p)`.
pub(super) fn run(
    sc: &Scene,
    mesh: &TetMesh,
    s: impl Fn([f64; 3]) -> f64,
) -> (Image, ReferenceStats) {
    run_tol(sc, mesh, s, 1e-6)
}

pub(super) fn run_tol(
    sc: &Scene,
    mesh: &TetMesh,
    s: impl Fn([f64; 3]) -> f64,
    tolerance: f64,
) -> (Image, ReferenceStats) {
    let s_norm: Vec<f64> = mesh.points.iter().map(|&p| s(p)).collect();
    let mut mesh = mesh.clone();
    mesh.fields = vec![Field {
        name: "s".into(),
        components: 1,
        values: s_norm.clone(),
    }];
    let adj = mesh.adjacency();
    let input = RenderInput {
        scene: sc.clone(),
        mesh: Arc::new(mesh),
        s_norm,
        range: [0.0, 1.0],
        pieces: None,
        renumbering: None,
    };
    let (img, st) = render(&input, &adj, &ReferenceOptions { tolerance });
    assert!(!img.has_non_finite());
    (img, st)
}

/// The 6-tet Kuhn split of each kept cell of an `n` grid of cubes of side `h`
/// (conforming across cells; half of the tets are negatively oriented).
pub(super) fn kuhn_grid(
    n: [usize; 3],
    origin: [f64; 3],
    h: f64,
    keep: impl Fn(usize, usize, usize) -> bool,
) -> TetMesh {
    let mut points = Vec::new();
    for k in 0..=n[2] {
        for j in 0..=n[1] {
            for i in 0..=n[0] {
                points.push([
                    origin[0] + i as f64 * h,
                    origin[1] + j as f64 * h,
                    origin[2] + k as f64 * h,
                ]);
            }
        }
    }
    let tets = kuhn_tets(n, keep);
    TetMesh {
        points,
        tets,
        fields: vec![],
    }
}

pub(super) fn merge(a: &TetMesh, b: &TetMesh) -> TetMesh {
    let off = a.points.len() as u32;
    let mut m = a.clone();
    m.points.extend(&b.points);
    m.tets.extend(b.tets.iter().map(|t| t.map(|v| v + off)));
    m
}

/// Where the ray `o + t d` is inside the box `[lo, hi]`, if it is (t >= 0).
pub(super) fn slab(o: [f64; 3], d: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k] < lo[k] || o[k] > hi[k] {
                return None;
            }
        } else {
            let (a, b) = ((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
    }
    (t1 > t0).then_some((t0, t1))
}

pub(super) fn at(o: [f64; 3], d: [f64; 3], t: f64) -> [f64; 3] {
    [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]]
}

/// Independent 1D emission–absorption integral over segments `(length, s0,
/// s1)` composited front to back: optical depth in closed form (opacity is
/// linear between control points, `∫ -ln(q) = -(q ln q - q)`), the colour
/// integral by adaptive Simpson (Richardson-checked) per kink-free piece.
/// Returns `(premultiplied rgb, transmittance)`.
pub(super) fn expected(segs: &[(f64, f64, f64)], tf: &TransferFunction) -> ([f64; 3], f64) {
    let omax = crate::scene::transfer::OPACITY_MAX;
    let mut c = [0.0; 3];
    let mut tr = 1.0;
    for &(len, s0, s1) in segs {
        // Cut points in s: control points and clamp crossings.
        let mut cuts: Vec<f64> = tf.points.iter().map(|p| p.s).collect();
        for w in tf.points.windows(2) {
            if (w[0].opacity - omax) * (w[1].opacity - omax) < 0.0 {
                cuts.push(
                    w[0].s
                        + (omax - w[0].opacity) / (w[1].opacity - w[0].opacity) * (w[1].s - w[0].s),
                );
            }
        }
        let mut us = vec![0.0, 1.0];
        if s1 != s0 {
            us.extend(
                cuts.iter()
                    .map(|k| (k - s0) / (s1 - s0))
                    .filter(|u| *u > 0.0 && *u < 1.0),
            );
        }
        us.sort_by(f64::total_cmp);
        for w in us.windows(2) {
            let (ua, ub) = (w[0], w[1]);
            let l = (ub - ua) * len;
            let (sa, sb) = (s0 + (s1 - s0) * ua, s0 + (s1 - s0) * ub);
            let qa = 1.0 - tf.eval(sa).1.min(omax);
            let qb = 1.0 - tf.eval(sb).1.min(omax);
            let f = |q: f64| q * q.ln() - q;
            // Optical depth from the piece start to fraction v.
            let depth = |v: f64| -> f64 {
                let q = qa + (qb - qa) * v;
                let integral = if (qb - qa).abs() > 1e-15 {
                    -(f(q) - f(qa)) / (qb - qa)
                } else {
                    -v * qa.ln()
                };
                l / tf.unit_distance * integral
            };
            let g = |v: f64| -> [f64; 3] {
                let (rgb, o) = tf.eval(sa + (sb - sa) * v);
                let e = -(1.0 - o.min(omax)).ln() / tf.unit_distance * (-depth(v)).exp();
                rgb.map(|x| x * e)
            };
            let acc = adaptive_simpson(&g, 0.0, 1.0, 1e-13, 0);
            for ch in 0..3 {
                c[ch] += tr * acc[ch] * l;
            }
            tr *= (-depth(1.0)).exp();
        }
    }
    (c, tr)
}

pub(super) fn adaptive_simpson(
    g: &impl Fn(f64) -> [f64; 3],
    a: f64,
    b: f64,
    tol: f64,
    depth: u32,
) -> [f64; 3] {
    let simpson = |a: f64, b: f64| -> [f64; 3] {
        let (fa, fm, fb) = (g(a), g(0.5 * (a + b)), g(b));
        [0, 1, 2].map(|k| (b - a) / 6.0 * (fa[k] + 4.0 * fm[k] + fb[k]))
    };
    let m = 0.5 * (a + b);
    let (whole, l, r) = (simpson(a, b), simpson(a, m), simpson(m, b));
    let err = (0..3)
        .map(|k| (l[k] + r[k] - whole[k]).abs())
        .fold(0.0, f64::max);
    if depth > 6 && (err < 15.0 * tol || depth > 45) {
        return [0, 1, 2].map(|k| l[k] + r[k] + (l[k] + r[k] - whole[k]) / 15.0);
    }
    let (x, y) = (
        adaptive_simpson(g, a, m, 0.5 * tol, depth + 1),
        adaptive_simpson(g, m, b, 0.5 * tol, depth + 1),
    );
    [0, 1, 2].map(|k| x[k] + y[k])
}

pub(super) fn assert_pixel(
    img: &Image,
    i: u32,
    j: u32,
    c: [f64; 3],
    tr: f64,
    bg: [f64; 3],
    tol: f64,
) {
    let p = img.get(i, j);
    let want = [
        c[0] + tr * bg[0],
        c[1] + tr * bg[1],
        c[2] + tr * bg[2],
        1.0 - tr,
    ];
    for ch in 0..4 {
        assert!(
            (p[ch] as f64 - want[ch]).abs() <= tol,
            "pixel ({i}, {j}) channel {ch}: got {:?}, want {:?}",
            p,
            want
        );
    }
}

pub(super) fn check_box_image(
    sc: &Scene,
    img: &Image,
    lo: [f64; 3],
    hi: [f64; 3],
    s: impl Fn([f64; 3]) -> f64,
    tol: f64,
) -> u32 {
    let view = sc.camera.view(sc.image.width, sc.image.height);
    let mut hits = 0;
    for j in 0..sc.image.height {
        for i in 0..sc.image.width {
            let (o, d) = view.ray(i, j);
            let segs: Vec<(f64, f64, f64)> = match slab(o, d, lo, hi) {
                Some((t0, t1)) => {
                    hits += 1;
                    vec![(t1 - t0, s(at(o, d, t0)), s(at(o, d, t1)))]
                }
                None => vec![],
            };
            let (c, tr) = expected(&segs, &sc.transfer);
            assert_pixel(img, i, j, c, tr, sc.image.background, tol);
        }
    }
    hits
}

pub(super) fn lin(p: [f64; 3]) -> f64 {
    (p[0] + 2.0 * p[1] + 3.0 * p[2]) / 18.0
}
