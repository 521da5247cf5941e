//! Analytic tests of the reference renderer: meshes built in code, expected
//! pixels from closed forms or from an independent 1D integration.

use std::sync::Arc;

use super::*;
use crate::data::lattice::kuhn_tets;
use crate::data::{Field, TetMesh};
use crate::scene::{Camera, DataSpec, ImageSpec, Projection, Scene, TransferFunction};

fn tf(points: &[[f64; 5]], ud: f64) -> TransferFunction {
    TransferFunction::from_rows(points, ud)
}

/// A transfer function with kinks and varying colour.
fn tf_ramp() -> TransferFunction {
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

fn scene(camera: Camera, w: u32, h: u32, bg: [f64; 3], transfer: TransferFunction) -> Scene {
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

fn ortho(eye: [f64; 3], target: [f64; 3], up: [f64; 3], height: f64) -> Camera {
    Camera {
        eye,
        target,
        up,
        projection: Projection::Orthographic { height },
    }
}

fn persp(eye: [f64; 3], target: [f64; 3], up: [f64; 3], fov: f64) -> Camera {
    Camera {
        eye,
        target,
        up,
        projection: Projection::Perspective { fov_y_deg: fov },
    }
}

/// Renders `mesh` with the per-vertex scalar `s(p)`.
fn run(sc: &Scene, mesh: &TetMesh, s: impl Fn([f64; 3]) -> f64) -> (Image, ReferenceStats) {
    run_tol(sc, mesh, s, 1e-6)
}

fn run_tol(
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
    };
    let (img, st) = render(&input, &adj, &ReferenceOptions { tolerance });
    assert!(!img.has_non_finite());
    (img, st)
}

/// The 6-tet Kuhn split of each kept cell of an `n` grid of cubes of side `h`
/// (conforming across cells; half of the tets are negatively oriented).
fn kuhn_grid(
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

fn merge(a: &TetMesh, b: &TetMesh) -> TetMesh {
    let off = a.points.len() as u32;
    let mut m = a.clone();
    m.points.extend(&b.points);
    m.tets.extend(b.tets.iter().map(|t| t.map(|v| v + off)));
    m
}

/// Where the ray `o + t d` is inside the box `[lo, hi]`, if it is (t >= 0).
fn slab(o: [f64; 3], d: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> Option<(f64, f64)> {
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

fn at(o: [f64; 3], d: [f64; 3], t: f64) -> [f64; 3] {
    [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]]
}

/// Independent 1D emission–absorption integral over segments `(length, s0,
/// s1)` composited front to back: optical depth in closed form (opacity is
/// linear between control points, `∫ -ln(q) = -(q ln q - q)`), the colour
/// integral by adaptive Simpson (Richardson-checked) per kink-free piece.
/// Returns `(premultiplied rgb, transmittance)`.
fn expected(segs: &[(f64, f64, f64)], tf: &TransferFunction) -> ([f64; 3], f64) {
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

fn adaptive_simpson(
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

fn assert_pixel(img: &Image, i: u32, j: u32, c: [f64; 3], tr: f64, bg: [f64; 3], tol: f64) {
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

#[test]
fn single_tet_constant_field_matches_closed_form() {
    let mesh = TetMesh {
        points: vec![
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.0, 0.0, 2.0],
        ],
        tets: vec![[0, 1, 2, 3]],
        fields: vec![],
    };
    let t = tf(&[[0.0, 0.9, 0.5, 0.1, 0.4], [1.0, 0.9, 0.5, 0.1, 0.4]], 0.7);
    let sc = scene(
        ortho([1.0, 1.0, 10.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], 2.2),
        33,
        33,
        [0.0; 3],
        t,
    );
    let (img, st) = run(&sc, &mesh, |_| 0.5);
    let view = sc.camera.view(33, 33);
    let mut hit = 0;
    for j in 0..33 {
        for i in 0..33 {
            let (o, _) = view.ray(i, j);
            let chord = if o[0] >= 0.0 && o[1] >= 0.0 {
                (2.0 - o[0] - o[1]).max(0.0)
            } else {
                0.0
            };
            hit += (chord > 0.0) as u32;
            let alpha = 1.0 - 0.6f64.powf(chord / 0.7);
            assert_pixel(
                &img,
                i,
                j,
                [0.9 * alpha, 0.5 * alpha, 0.1 * alpha],
                1.0 - alpha,
                [0.0; 3],
                2e-6,
            );
        }
    }
    assert!(hit > 100);
    assert_eq!(st.walk_recoveries, 0);
}

/// Kuhn grid [0,3]^3, rays along -z, many exactly along grid edges and in
/// faces (pixel size 1/8, pixel centres on the grid lines).
#[test]
fn cube_linear_field_along_view_and_rays_along_edges() {
    let mesh = kuhn_grid([3, 3, 3], [0.0; 3], 1.0, |_, _, _| true);
    let t = tf_ramp();
    let (w, h) = (31, 31);
    let sc = scene(
        ortho([1.5, 1.5, 10.0], [1.5, 1.5, 0.0], [0.0, 1.0, 0.0], 3.875),
        w,
        h,
        [0.0; 3],
        t.clone(),
    );
    let (img, st) = run(&sc, &mesh, |p| p[2] / 3.0);
    let (c, tr) = expected(&[(3.0, 1.0, 0.0)], &t);
    let view = sc.camera.view(w, h);
    let mut on_grid_lines = 0;
    for j in 0..h {
        for i in 0..w {
            let (o, _) = view.ray(i, j);
            let inside = o[0] > 0.0 && o[0] < 3.0 && o[1] > 0.0 && o[1] < 3.0;
            let outside = o[0] < 0.0 || o[0] > 3.0 || o[1] < 0.0 || o[1] > 3.0;
            if inside {
                on_grid_lines += (o[0].fract() == 0.0 || o[1].fract() == 0.0) as u32;
                assert_pixel(&img, i, j, c, tr, [0.0; 3], 2e-6);
            } else if outside {
                assert_pixel(&img, i, j, [0.0; 3], 1.0, [0.0; 3], 0.0);
            }
        }
    }
    assert!(on_grid_lines >= 50, "{on_grid_lines}");
    assert_eq!(st.walks_abandoned, 0);
}

fn check_box_image(
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

fn lin(p: [f64; 3]) -> f64 {
    (p[0] + 2.0 * p[1] + 3.0 * p[2]) / 18.0
}

#[test]
fn cube_skew_perspective_and_main_diagonal_through_vertices() {
    let mesh = kuhn_grid([3, 3, 3], [0.0; 3], 1.0, |_, _, _| true);
    // The centre pixel's ray runs along the Kuhn diagonal edges (0,0,0) ->
    // (3,3,3), through four vertices; its neighbours pass near them.
    let sc = scene(
        persp([-2.0, -2.0, -2.0], [1.0, 1.0, 1.0], [0.0, 0.0, 1.0], 50.0),
        41,
        41,
        [0.0; 3],
        tf_ramp(),
    );
    let (img, st) = run(&sc, &mesh, lin);
    let hits = check_box_image(&sc, &img, [0.0; 3], [3.0; 3], lin, 3e-6);
    assert!(hits > 500, "{hits}");
    assert_eq!(st.walks_abandoned, 0);
    // Ray through vertex (1,1,1) in a generic direction (not along an edge).
    let sc = scene(
        ortho([-4.0, -9.0, -14.0], [1.0, 1.0, 1.0], [0.0, 0.0, 1.0], 4.0),
        21,
        21,
        [0.0; 3],
        tf_ramp(),
    );
    let (img, _) = run(&sc, &mesh, lin);
    check_box_image(&sc, &img, [0.0; 3], [3.0; 3], lin, 3e-6);
}

#[test]
fn perspective_eye_inside_the_mesh() {
    let mesh = kuhn_grid([3, 3, 3], [0.0; 3], 1.0, |_, _, _| true);
    let sc = scene(
        persp([1.3, 1.7, 1.1], [3.0, 2.0, 2.5], [0.0, 0.0, 1.0], 100.0),
        25,
        25,
        [0.0; 3],
        tf_ramp(),
    );
    let (img, st) = run(&sc, &mesh, lin);
    check_box_image(&sc, &img, [0.0; 3], [3.0; 3], lin, 3e-6);
    assert_eq!(st.origin_inside, 25 * 25);
    // Exactly on a grid vertex.
    let sc = scene(
        persp([1.0, 2.0, 1.0], [3.0, 2.5, 2.5], [0.0, 0.0, 1.0], 100.0),
        25,
        25,
        [0.0; 3],
        tf_ramp(),
    );
    let (img, st) = run(&sc, &mesh, lin);
    check_box_image(&sc, &img, [0.0; 3], [3.0; 3], lin, 3e-6);
    assert_eq!(st.origin_inside, 25 * 25);
}

#[test]
fn two_disjoint_cubes_are_both_counted() {
    let a = kuhn_grid([1, 1, 1], [0.0, 0.0, 2.0], 1.0, |_, _, _| true);
    let b = kuhn_grid([2, 2, 1], [0.0, 0.0, 0.0], 0.5, |_, _, _| true);
    let mesh = merge(&a, &b);
    let sc = scene(
        ortho([0.5, 0.5, 10.0], [0.5, 0.5, 0.0], [0.0, 1.0, 0.0], 1.4),
        15,
        15,
        [0.0; 3],
        tf_ramp(),
    );
    let s = |p: [f64; 3]| p[2] / 3.0;
    let (img, st) = run(&sc, &mesh, s);
    let (c, tr) = expected(
        &[(1.0, 1.0, 2.0 / 3.0), (0.5, 0.5 / 3.0, 0.0)],
        &sc.transfer,
    );
    let view = sc.camera.view(15, 15);
    let mut n = 0;
    for j in 0..15 {
        for i in 0..15 {
            let (o, _) = view.ray(i, j);
            if o[0] > 0.0 && o[0] < 1.0 && o[1] > 0.0 && o[1] < 0.5 {
                assert_pixel(&img, i, j, c, tr, [0.0; 3], 2e-6);
                n += 1;
            }
        }
    }
    assert!(n > 20);
    assert!(st.mesh_entries >= 2 * n as u64);
}

/// A square ring (3 x 3 cells minus the centre), seen along +x: rays through
/// the middle row cross an arm, the hole, and the other arm.
#[test]
fn concave_ring_counts_every_entry() {
    let mesh = kuhn_grid([3, 3, 1], [0.0; 3], 1.0, |i, j, _| !(i == 1 && j == 1));
    let s = |p: [f64; 3]| p[0] / 3.0 + 0.1 * p[2];
    let t = tf_ramp();
    let sc = scene(
        ortho([-5.0, 1.5, 0.5], [0.0, 1.5, 0.5], [0.0, 0.0, 1.0], 1.2),
        41,
        13,
        [0.0; 3],
        t.clone(),
    );
    let (img, _) = run(&sc, &mesh, s);
    let view = sc.camera.view(41, 13);
    let mut both = 0;
    for j in 0..13 {
        for i in 0..41 {
            let (o, d) = view.ray(i, j);
            let (y, z) = (o[1], o[2]);
            if !(z > 0.0 && z < 1.0 && y > 0.0 && y < 3.0) || y.fract() == 0.0 {
                continue;
            }
            let segs = if y > 1.0 && y < 2.0 {
                both += 1;
                vec![
                    (1.0, s([0.0, y, z]), s([1.0, y, z])),
                    (1.0, s([2.0, y, z]), s([3.0, y, z])),
                ]
            } else {
                vec![(3.0, s([0.0, y, z]), s([3.0, y, z]))]
            };
            assert!(d[0] > 0.999_999);
            let (c, tr) = expected(&segs, &t);
            assert_pixel(&img, i, j, c, tr, [0.0; 3], 2e-6);
        }
    }
    assert!(both > 100);
    // Perspective eye in the hole: inside the bounding box, outside the mesh.
    let sc = scene(
        persp([1.5, 1.5, 0.5], [3.0, 1.5, 0.5], [0.0, 0.0, 1.0], 40.0),
        15,
        15,
        [0.0; 3],
        t.clone(),
    );
    let (img, st) = run(&sc, &mesh, s);
    assert_eq!(st.origin_inside, 0);
    let view = sc.camera.view(15, 15);
    for j in 0..15 {
        for i in 0..15 {
            let (o, d) = view.ray(i, j);
            let segs: Vec<_> = slab(o, d, [2.0, 0.0, 0.0], [3.0, 3.0, 1.0])
                .map(|(t0, t1)| {
                    let (p0, p1) = (at(o, d, t0), at(o, d, t1));
                    // Through the far arm only if it enters by the x = 2 face.
                    if (p0[0] - 2.0).abs() < 1e-12 {
                        (t1 - t0, s(p0), s(p1))
                    } else {
                        (0.0, 0.0, 0.0)
                    }
                })
                .into_iter()
                .collect();
            if segs.iter().all(|s| s.0 > 0.0) {
                let (c, tr) = expected(&segs, &t);
                assert_pixel(&img, i, j, c, tr, [0.0; 3], 2e-6);
            }
        }
    }
}

#[test]
fn background_is_composited_under_the_volume() {
    let mesh = kuhn_grid([1, 1, 1], [0.0; 3], 1.0, |_, _, _| true);
    let bg = [0.2, 0.4, 0.6];
    let t = tf(&[[0.0, 1.0, 0.5, 0.0, 0.3], [1.0, 1.0, 0.5, 0.0, 0.3]], 1.0);
    let sc = scene(
        ortho([0.5, 0.5, 5.0], [0.5, 0.5, 0.0], [0.0, 1.0, 0.0], 2.0),
        9,
        9,
        bg,
        t,
    );
    let (img, _) = run(&sc, &mesh, |_| 0.0);
    let alpha = 0.3;
    assert_pixel(&img, 4, 4, [alpha, 0.5 * alpha, 0.0], 1.0 - alpha, bg, 2e-6);
    assert_pixel(&img, 0, 0, [0.0; 3], 1.0, bg, 1e-7);
}

#[test]
fn opacity_one_is_clamped() {
    let mesh = kuhn_grid([1, 1, 1], [0.0; 3], 1.0, |_, _, _| true);
    let t = tf(
        &[[0.0, 0.5, 0.5, 0.5, 1.0], [1.0, 0.5, 0.5, 0.5, 1.0]],
        10.0,
    );
    let sc = scene(
        ortho([0.5, 0.5, 5.0], [0.5, 0.5, 0.0], [0.0, 1.0, 0.0], 2.0),
        9,
        9,
        [0.0; 3],
        t,
    );
    let (img, _) = run(&sc, &mesh, |_| 0.3);
    let alpha = 1.0 - 1e-6f64.powf(0.1);
    assert_pixel(&img, 4, 4, [0.5 * alpha; 3], 1.0 - alpha, [0.0; 3], 2e-6);
    // A ramp up to 1: the clamp makes a kink just below s = 1.
    let t = tf(&[[0.0, 0.0, 0.3, 1.0, 0.2], [1.0, 1.0, 0.3, 0.0, 1.0]], 2.0);
    let sc = scene(
        ortho([0.5, 0.5, 5.0], [0.5, 0.5, 0.0], [0.0, 1.0, 0.0], 2.0),
        9,
        9,
        [0.0; 3],
        t.clone(),
    );
    let (img, st) = run(&sc, &mesh, |p| 1.0 - p[2]);
    let (c, tr) = expected(&[(1.0, 0.0, 1.0)], &t);
    assert_pixel(&img, 4, 4, c, tr, [0.0; 3], 2e-6);
    assert_eq!(st.quadrature_depth_limited, 0);
}

#[test]
fn offset_by_1e6_gives_the_same_image() {
    let mesh = kuhn_grid([3, 3, 3], [0.0; 3], 1.0, |_, _, _| true);
    let off = 1e6;
    let mut far = mesh.clone();
    for p in &mut far.points {
        *p = [p[0] + off, p[1] + off, p[2] + off];
    }
    let cam = persp([-2.0, -1.0, -1.5], [1.5, 1.4, 1.6], [0.0, 0.0, 1.0], 45.0);
    let sc = scene(cam, 31, 31, [0.1, 0.2, 0.3], tf_ramp());
    let mut cam_far = cam;
    cam_far.eye = cam.eye.map(|v| v + off);
    cam_far.target = cam.target.map(|v| v + off);
    let sc_far = scene(cam_far, 31, 31, [0.1, 0.2, 0.3], tf_ramp());
    let (a, _) = run(&sc, &mesh, lin);
    let (b, st) = run(&sc_far, &far, |p| lin([p[0] - off, p[1] - off, p[2] - off]));
    let e = b.error_against(&a);
    assert!(e.max_abs / 255.0 < 1e-6, "{e}");
    assert_eq!(st.walks_abandoned, 0);
    // Orthographic too.
    let cam = ortho([-2.0, -1.0, -1.5], [1.5, 1.4, 1.6], [0.0, 0.0, 1.0], 5.0);
    let mut cam_far = cam;
    cam_far.eye = cam.eye.map(|v| v + off);
    cam_far.target = cam.target.map(|v| v + off);
    let (a, _) = run(&scene(cam, 31, 31, [0.0; 3], tf_ramp()), &mesh, lin);
    let (b, _) = run(&scene(cam_far, 31, 31, [0.0; 3], tf_ramp()), &far, |p| {
        lin([p[0] - off, p[1] - off, p[2] - off])
    });
    let e = b.error_against(&a);
    assert!(e.max_abs / 255.0 < 1e-6, "{e}");
}

/// An octahedron made of two top tets (diagonal a-c), two bottom tets
/// (diagonal b-d) and the zero-volume tet (a, b, c, d) between them.
fn octahedron(dz: f64) -> TetMesh {
    TetMesh {
        points: vec![
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, -1.0, dz],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ],
        tets: vec![
            [0, 1, 2, 4],
            [0, 2, 3, 4],
            [0, 1, 3, 5],
            [1, 2, 3, 5],
            [0, 1, 2, 3],
        ],
        fields: vec![],
    }
}

#[test]
fn zero_volume_and_sliver_tets_do_not_break_the_walk() {
    let s = |p: [f64; 3]| 0.5 + 0.4 * p[2] + 0.1 * p[0];
    for dz in [0.0, 1e-12, -1e-9] {
        let mesh = octahedron(dz);
        assert_eq!(
            mesh.adjacency().neighbors[4]
                .iter()
                .filter(|&&n| n != crate::data::NO_NEIGHBOR)
                .count(),
            4
        );
        // Pixel centres on the diagonals and the axes (pixel size 1/8).
        let sc = scene(
            ortho([0.0, 0.0, 5.0], [0.0; 3], [0.0, 1.0, 0.0], 17.0 / 8.0),
            17,
            17,
            [0.0; 3],
            tf_ramp(),
        );
        let (img, st) = run(&sc, &mesh, s);
        let view = sc.camera.view(17, 17);
        for j in 0..17 {
            for i in 0..17 {
                let (o, _) = view.ray(i, j);
                let r = o[0].abs() + o[1].abs();
                if r >= 1.0 - 1e-9 {
                    continue;
                }
                let half = 1.0 - r;
                // Linear field: exact whatever the tets (flat tet at dz = 0).
                let segs = [(2.0 * half, s([o[0], o[1], half]), s([o[0], o[1], -half]))];
                let (c, tr) = expected(&segs, &sc.transfer);
                // dz != 0 bends the field by up to |dz| / 1: allow for it.
                assert_pixel(&img, i, j, c, tr, [0.0; 3], 2e-6 + 10.0 * dz.abs());
            }
        }
        assert_eq!(st.walks_abandoned, 0);
    }
}

#[test]
fn same_image_for_any_thread_count() {
    let mesh = kuhn_grid([3, 3, 3], [0.0; 3], 1.0, |i, j, _| !(i == 1 && j == 1));
    let sc = scene(
        persp([-2.0, -1.0, -1.5], [1.5, 1.4, 1.6], [0.0, 0.0, 1.0], 45.0),
        40,
        30,
        [0.0; 3],
        tf_ramp(),
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| run(&sc, &mesh, lin));
    let three = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| run(&sc, &mesh, lin));
    assert_eq!(one.0, three.0);
    assert_eq!(one.1.tets_visited, three.1.tets_visited);
}

#[test]
fn tighter_tolerance_moves_pixels_by_less_than_the_tolerance() {
    let mesh = kuhn_grid([3, 3, 3], [0.0; 3], 1.0, |_, _, _| true);
    // Thick: optical depth up to ~13 over the cube.
    let t = tf(
        &[
            [0.0, 0.1, 0.2, 0.9, 0.0],
            [0.3, 0.2, 0.8, 0.3, 0.95],
            [0.55, 0.9, 0.9, 0.1, 0.1],
            [1.0, 1.0, 0.1, 0.1, 0.99],
        ],
        0.5,
    );
    let sc = scene(
        persp([-2.0, -1.0, -1.5], [1.5, 1.4, 1.6], [0.0, 0.0, 1.0], 45.0),
        31,
        31,
        [0.0; 3],
        t,
    );
    let (a, sa) = run_tol(&sc, &mesh, lin, 1e-4);
    let (b, sb) = run_tol(&sc, &mesh, lin, 1e-12);
    assert!(sb.quadrature_rules > sa.quadrature_rules);
    let e = a.error_against(&b);
    assert!(e.max_abs / 255.0 < 1e-4, "{e}");
    check_box_image(&sc, &b, [0.0; 3], [3.0; 3], lin, 1e-6);
}

#[test]
fn empty_mesh_and_missed_rays_give_the_background() {
    let sc = scene(
        ortho([0.0, 0.0, 5.0], [0.0; 3], [0.0, 1.0, 0.0], 2.0),
        4,
        4,
        [0.3, 0.3, 0.3],
        tf_ramp(),
    );
    let (img, st) = run(&sc, &TetMesh::default(), |_| 0.0);
    assert_eq!(st.rays_hit, 0);
    assert!(img.pixels.iter().all(|p| *p == [0.3, 0.3, 0.3, 0.0]));
}

/// A 4x4x4 Kuhn grid whose interior vertices are jittered (boundary kept),
/// with a linear field: any ray's exact answer is the 1D integral over the
/// box chord. Rays are aimed exactly at interior vertices and edge
/// midpoints, and run along edges.
#[test]
fn irregular_mesh_rays_through_vertices_edges_and_along_edges() {
    let n = 4;
    let mut mesh = kuhn_grid([n, n, n], [0.0; 3], 1.0, |_, _, _| true);
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    for p in &mut mesh.points {
        if p.iter().all(|&v| v > 0.0 && v < n as f64) {
            *p = [p[0] + 0.3 * rnd(), p[1] + 0.3 * rnd(), p[2] + 0.3 * rnd()];
        }
    }
    assert!((0..mesh.tets.len()).all(|t| mesh.tet_volume(t).abs() > 1e-3));
    let hi = [n as f64; 3];
    let s = |p: [f64; 3]| (p[0] - 0.5 * p[1] + 0.7 * p[2]) / 5.0 + 0.2;
    let mut recoveries = 0;
    let mut checked = 0;
    for (t, tet) in mesh.tets.iter().enumerate().step_by(13) {
        let v = mesh.points[tet[t % 4] as usize];
        let w = mesh.points[tet[(t + 1) % 4] as usize];
        let mid = [
            0.5 * (v[0] + w[0]),
            0.5 * (v[1] + w[1]),
            0.5 * (v[2] + w[2]),
        ];
        let dir = [w[0] - v[0], w[1] - v[1], w[2] - v[2]];
        let up = if dir[0].abs() < 0.9 * dir.iter().map(|x| x * x).sum::<f64>().sqrt() {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let cams = [
            // Through a vertex, from outside (centre pixel of an odd image).
            persp([-3.0, -2.5, -4.0], v, [0.0, 0.0, 1.0], 0.5),
            // Through an edge midpoint.
            persp([-3.0, 7.5, -2.0], mid, [0.0, 0.0, 1.0], 0.5),
            // Along an edge (orthographic, centre ray on the edge's line).
            ortho(
                [
                    v[0] - 10.0 * dir[0],
                    v[1] - 10.0 * dir[1],
                    v[2] - 10.0 * dir[2],
                ],
                v,
                up,
                0.05,
            ),
            // From inside, through a vertex.
            persp([2.1, 1.9, 2.05], v, [0.0, 0.0, 1.0], 0.5),
        ];
        for (ci, cam) in cams.into_iter().enumerate() {
            // A ray lying in the boundary's plane is ambiguous: skip it.
            let in_boundary = (0..3).any(|k| dir[k] == 0.0 && (v[k] == 0.0 || v[k] == n as f64));
            if cam.check().is_err() || (ci == 2 && in_boundary) {
                continue;
            }
            let sc = scene(cam, 3, 3, [0.0; 3], tf_ramp());
            let (img, st) = run(&sc, &mesh, s);
            recoveries += st.walk_recoveries;
            assert_eq!(st.walks_abandoned, 0);
            let view = sc.camera.view(3, 3);
            let (o, d) = view.ray(1, 1);
            let segs: Vec<_> = slab(o, d, [0.0; 3], hi)
                .map(|(t0, t1)| (t1 - t0, s(at(o, d, t0)), s(at(o, d, t1))))
                .into_iter()
                .collect();
            let (c, tr) = expected(&segs, &sc.transfer);
            assert_pixel(&img, 1, 1, c, tr, [0.0; 3], 3e-6);
            checked += 1;
        }
    }
    assert!(checked > 80, "{checked}");
    eprintln!("{checked} exact rays, {recoveries} recoveries");
}
