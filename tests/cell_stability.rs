//! Numerical stability of the cell-projection renderer: meshes whose exact
//! image is known in closed form (a constant-extinction box or tet: alpha =
//! 1 - (1 - o)^(L / unit_distance) with L the f64 chord), seen in the
//! configurations where scan conversion is fragile: shared faces, edges and
//! vertices exactly on pixel-centre rays, faces seen edge-on, degenerate and
//! sliver cells, far-from-origin coordinates, opacity 1, and the thread count
//! and tile size (which must not change a bit).
//!
//! Every render is checked for NaN and infinity (`render_finite`).

mod common;

use common::*;
use pvrsim::data::TetMesh;
use pvrsim::image::Image;
use pvrsim::render::cell::{self, CellOptions, CellOrder, Integrator};
use pvrsim::render::RenderInput;
use pvrsim::scene::Scene;

const TOL: f64 = 1e-4;

/// Checks `img` against the analytic `want` within `tol`, every channel of
/// every pixel, and returns the largest error.
fn assert_analytic(what: &str, img: &Image, want: &[[f64; 4]], tol: f64) -> f64 {
    let (err, k) = max_err(img, want);
    let (i, j) = (k as u32 % img.width, k as u32 / img.width);
    assert!(
        err <= tol,
        "{what}: pixel ({i}, {j}) got {:?}, want {:?} (error {err:e} > {tol:e})",
        img.pixels[k],
        want[k]
    );
    err
}

/// Smoothness: two neighbouring pixels whose rays both cross the volume
/// differ by what their chords imply, within `tol` (a crack or a doubly
/// covered sliver is a local step that the analytic image does not have).
fn assert_smooth(what: &str, img: &Image, want: &[[f64; 4]], covered: &[bool], tol: f64) -> f64 {
    let w = img.width as usize;
    let mut worst = 0.0f64;
    for k in 0..img.pixels.len() {
        for n in [k + 1, k + w] {
            if n >= img.pixels.len() || (n == k + 1 && n % w == 0) || !covered[k] || !covered[n] {
                continue;
            }
            let (pn, pk) = (img.pixels[n], img.pixels[k]);
            for (c, (wn, wk)) in want[n].iter().zip(&want[k]).enumerate() {
                let got = pn[c] as f64 - pk[c] as f64;
                let exp = wn - wk;
                let e = (got - exp).abs();
                worst = worst.max(e);
                assert!(
                    e <= tol,
                    "{what}: step between pixels ({}, {}) and ({}, {}) channel {c} is {got:e}, chords imply {exp:e}",
                    k % w,
                    k / w,
                    n % w,
                    n / w
                );
            }
        }
    }
    worst
}

/// Pixels whose ray crosses the box `[lo, hi]` by more than `min_len`.
fn covered(scene: &Scene, lo: [f64; 3], hi: [f64; 3], min_len: f64) -> Vec<bool> {
    let v = scene.view();
    let mut out = Vec::new();
    for j in 0..v.height {
        for i in 0..v.width {
            out.push(chord(scene, i, j, lo, hi) > min_len);
        }
    }
    out
}

/// Renders a constant box with every integrator and cell order and checks it
/// against the analytic image (and smoothness); returns the largest error.
fn check_box(
    what: &str,
    mesh: &TetMesh,
    cam: &Cam,
    look: &Look,
    lo: [f64; 3],
    hi: [f64; 3],
) -> f64 {
    let input = input(mesh.clone(), cam, look);
    let want = analytic_box_image(&input.scene, look, lo, hi);
    let cov = covered(&input.scene, lo, hi, 1e-3);
    let mut worst = 0.0f64;
    for integ in INTEGRATORS {
        for order in ORDERS {
            let o = opts(integ, order);
            let (img, _) = render_finite(&input, &o);
            let tag = format!("{what} {integ} {order}");
            let e = assert_analytic(&tag, &img, &want, TOL);
            let s = assert_smooth(&tag, &img, &want, &cov, 2.0 * TOL);
            eprintln!("{tag}: max error {e:.2e}, max step error {s:.2e}");
            worst = worst.max(e);
        }
    }
    worst
}

// ------------------------------------------------------------ 1. no cracks

#[test]
fn no_cracks_in_a_uniform_cube_oblique_views() {
    let mesh = cube_mesh(8, [-4.0; 3], 8.0, |_| 0.5);
    let (lo, hi) = ([-4.0; 3], [4.0; 3]);
    let look = Look::constant(101, 97, [0.9, 0.5, 0.2], 0.3, 2.0);
    let eye = [23.0, 17.0, 11.0];
    let ortho = Cam::ortho(eye, [0.0; 3], [0.0, 0.0, 1.0], 16.0);
    let persp = Cam::persp(eye, [0.0; 3], [0.1, 0.0, 1.0], 34.0);
    let a = check_box("oblique ortho", &mesh, &ortho, &look, lo, hi);
    let b = check_box("oblique persp", &mesh, &persp, &look, lo, hi);
    // The test is only worth something if the image is not trivially
    // background: most pixels see the cube through many cells.
    let input = input(mesh, &ortho, &look);
    let (_, stats) = cell::render(&input, &CellOptions::default());
    assert!(stats.pixels_covered > 3000, "{stats:?}");
    eprintln!("no cracks: max error ortho {a:.2e}, persp {b:.2e}");
}

// ------------------------------------------------------- 2. edge-on faces

/// Looking exactly along -y at an axis-aligned cube with 1/8-unit pixels,
/// offset so that every lattice plane `x = c` and `z = c` (and the Kuhn
/// planes `x - z = c`) passes exactly through pixel centres: those faces are
/// parallel to the rays and rays lie in them. The cube is larger than the
/// view, so no ray lies in an outer face (where the chord would be
/// ambiguous); every chord is 8.
#[test]
fn edge_on_faces_axis_aligned_view() {
    let mesh = cube_mesh(8, [-4.0; 3], 8.0, |_| 0.5);
    let look = Look::constant(48, 48, [0.9, 0.5, 0.2], 0.3, 2.0);
    let c = 1.0 / 16.0;
    let cam = Cam::ortho([c, -20.0, c], [c, 0.0, c], [0.0, 0.0, 1.0], 6.0);
    let e = check_box("edge-on ortho", &mesh, &cam, &look, [-4.0; 3], [4.0; 3]);
    eprintln!("edge-on ortho: max error {e:.2e}");
}

/// Perspective, eye in the lattice planes `x = 0` and `z = 0`, odd image
/// size: the centre column's rays lie in the plane `x = 0`, the centre row's
/// in `z = 0`, and the centre pixel's ray runs along the lattice edges on the
/// y axis (tet edges of the Kuhn split).
#[test]
fn edge_on_faces_perspective_eye_in_lattice_planes() {
    let mesh = cube_mesh(8, [-4.0; 3], 8.0, |_| 0.5);
    let look = Look::constant(41, 41, [0.9, 0.5, 0.2], 0.3, 2.0);
    let cam = Cam::persp([0.0, -20.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 20.0);
    let e = check_box("edge-on persp", &mesh, &cam, &look, [-4.0; 3], [4.0; 3]);
    eprintln!("edge-on persp: max error {e:.2e}");
}

/// Looking exactly along the main diagonal `(1, 1, 1)`: it is an edge of all
/// six tets of every cell, so every interior Kuhn face is seen edge-on (in
/// f32 too: the cell diagonal's ends project to the same point), and with an
/// odd image the centre pixel's ray runs exactly along the chain of diagonal
/// edges through the cube's centre, the centre column in the planes `x = y`.
#[test]
fn camera_along_a_tet_edge() {
    let mesh = cube_mesh(6, [-3.0; 3], 6.0, |_| 0.5);
    let look = Look::constant(61, 61, [0.9, 0.5, 0.2], 0.3, 2.0);
    let cam = Cam::ortho([20.0, 20.0, 20.0], [0.0; 3], [0.0, 0.0, 1.0], 12.0);
    let e = check_box(
        "along the diagonal edge",
        &mesh,
        &cam,
        &look,
        [-3.0; 3],
        [3.0; 3],
    );
    // The centre pixel: chord 6 sqrt 3 along the diagonal edges.
    let input = input(mesh, &cam, &look);
    let (img, _) = render_finite(&input, &CellOptions::default());
    let want = slab_pixel(
        6.0 * 3f64.sqrt(),
        [0.9, 0.5, 0.2],
        0.3,
        2.0,
        look.background,
    );
    let got = img.get(30, 30);
    assert!(
        (got[3] as f64 - want[3]).abs() < TOL,
        "centre pixel {got:?}, want {want:?}"
    );
    eprintln!("along a tet edge: max error {e:.2e}");
}

// ------------------------------------------ 3. vertices on pixel centres

/// An oblique view (no face is parallel to the rays) in which lattice
/// vertices project exactly onto pixel centres (those with
/// `3x + 4y + 12z = 0 mod 13`) and every vertex onto a pixel-centre column.
#[test]
fn vertices_exactly_on_pixel_centres() {
    let mesh = cube_mesh(4, [-10.0; 3], 20.0, |_| 0.5);
    let (w, h) = (121, 141);
    let look = Look::constant(w, h, [0.9, 0.5, 0.2], 0.3, 8.0);
    let cam = rational_cam([0.0; 3], 0.25, h);
    // How many vertices land exactly on a pixel centre (in f64, so in f32 too).
    let input = input(mesh.clone(), &cam, &look);
    let view = input.scene.view();
    let on_centre = mesh
        .points
        .iter()
        .filter(|&&p| {
            let q = view.camera_to_pixel(view.to_camera(p)).unwrap();
            q.iter()
                .all(|&v| ((v - 0.5).round() + 0.5 - v).abs() < 1e-9)
        })
        .count();
    assert!(on_centre >= 8, "only {on_centre} vertices on pixel centres");
    let e = check_box(
        "vertices on pixel centres",
        &mesh,
        &cam,
        &look,
        [-10.0; 3],
        [10.0; 3],
    );
    eprintln!(
        "{on_centre} of {} vertices on pixel centres; max error {e:.2e}",
        mesh.points.len()
    );
}

// ---------------------------------------------- 4. degenerate and slivers

/// A scalar field given by position.
type FieldFn = fn([f64; 3]) -> f64;

/// A smooth, gently varying field (linear, so subdividing a tet reproduces
/// it exactly).
fn linear_field(p: [f64; 3]) -> f64 {
    0.5 + 0.012 * (p[0] + 2.0 * p[1] - p[2])
}

/// Zero-volume tets over the lattice of `cube_mesh(4, [-4; 3], 8, ..)`:
/// repeated vertices, four points on an axis plane, on a diagonal plane, on
/// a line. They cover no volume, so they must not change the image.
fn zero_volume_tets() -> Vec<[u32; 4]> {
    let v = |i, j, k| lattice_index(4, i, j, k);
    vec![
        [v(1, 1, 1), v(1, 1, 1), v(2, 1, 1), v(1, 2, 2)],
        [v(2, 2, 2), v(3, 2, 1), v(3, 2, 1), v(3, 2, 1)],
        [v(0, 0, 0), v(0, 0, 0), v(0, 0, 0), v(0, 0, 0)],
        [v(3, 3, 0), v(1, 3, 0), v(3, 3, 0), v(1, 1, 4)],
        // Axis plane z = const.
        [v(1, 1, 2), v(2, 1, 2), v(1, 2, 2), v(2, 2, 2)],
        [v(0, 0, 3), v(4, 0, 3), v(0, 4, 3), v(4, 4, 3)],
        // Diagonal plane x - y = const.
        [v(1, 1, 1), v(2, 2, 1), v(1, 1, 3), v(2, 2, 3)],
        [v(0, 1, 0), v(3, 4, 0), v(0, 1, 4), v(3, 4, 4)],
        // Plane x + y + z = 3 (not through a lattice direction).
        [v(3, 0, 0), v(0, 3, 0), v(0, 0, 3), v(1, 1, 1)],
        // A line.
        [v(0, 2, 2), v(1, 2, 2), v(2, 2, 2), v(4, 2, 2)],
    ]
}

/// Replaces every `stride`-th tet `(a, b, c, d)` of `mesh` by four, around a new
/// point `p` at `1e-7` from face `abc` (inside): `(p, b, c, d)`, `(a, p, c, d)`,
/// `(a, b, p, d)` and the sliver `(a, b, c, p)`. The same volume, still
/// conforming, and the linear field is reproduced. Returns the number of slivers.
fn add_slivers(mesh: &mut TetMesh, stride: usize, field: impl Fn([f64; 3]) -> f64) -> usize {
    let n = mesh.tets.len();
    let mut count = 0;
    for t in (3..n).step_by(stride) {
        let [a, b, c, d] = mesh.tets[t];
        let [pa, pb, pc, pd] = [a, b, c, d].map(|v| mesh.points[v as usize]);
        let e1 = [pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]];
        let e2 = [pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]];
        let mut nrm = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let len = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt();
        let side = nrm[0] * (pd[0] - pa[0]) + nrm[1] * (pd[1] - pa[1]) + nrm[2] * (pd[2] - pa[2]);
        let sign = if side > 0.0 { 1.0 } else { -1.0 };
        nrm = nrm.map(|x| sign * x / len);
        let p: [f64; 3] = std::array::from_fn(|k| (pa[k] + pb[k] + pc[k]) / 3.0 + 1e-7 * nrm[k]);
        let pi = mesh.points.len() as u32;
        mesh.points.push(p);
        mesh.fields[0].values.push(field(p));
        mesh.tets[t] = [pi, b, c, d];
        mesh.tets.push([a, pi, c, d]);
        mesh.tets.push([a, b, pi, d]);
        mesh.tets.push([a, b, c, pi]);
        count += 1;
    }
    count
}

/// Tets with `6 |V| <= rel * |e1| |e2| |e3|` (f64).
fn thin_tets(mesh: &TetMesh, rel: f64) -> u64 {
    let len = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (0..mesh.tets.len())
        .filter(|&t| {
            let [a, b, c, d] = mesh.tets[t].map(|v| mesh.points[v as usize]);
            let e = [b, c, d].map(|p| [p[0] - a[0], p[1] - a[1], p[2] - a[2]]);
            (6.0 * mesh.tet_volume(t)).abs() <= rel * len(e[0]) * len(e[1]) * len(e[2])
        })
        .count() as u64
}

/// Whether the projected bounding box of `tet` holds a pixel centre (f64),
/// and whether that is clear-cut (no box side within 1e-6 of a centre).
fn reaches_scan(view: &pvrsim::scene::View, mesh: &TetMesh, tet: [u32; 4]) -> (bool, bool) {
    let px = tet.map(|v| {
        view.camera_to_pixel(view.to_camera(mesh.points[v as usize]))
            .unwrap()
    });
    let (xl, xh) = (
        px.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
        px.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max),
    );
    let (yl, yh) = (
        px.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min),
        px.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max),
    );
    let near = |v: f64| ((v - 0.5).round() + 0.5 - v).abs() < 1e-6;
    let clear = ![xl, xh, yl, yh].into_iter().any(near);
    let has = (xl - 0.5).ceil() <= (xh - 0.5).floor() && (yl - 0.5).ceil() <= (yh - 0.5).floor();
    let inside = xh >= 0.0 && yh >= 0.0 && xl <= view.width as f64 && yl <= view.height as f64;
    (has && inside, clear)
}

/// Zero-volume tets (repeated vertices; four points on a plane or a line)
/// added to a valid mesh, and tets split around a point 1e-7 from a face so
/// that one of the four parts is a sliver: no NaN, the image is that of the
/// plain mesh within 1e-4, and `cells_degenerate` counts each zero-volume tet
/// that reaches scan conversion once, whatever the tile size.
///
/// The field is linear (splitting a tet reproduces it exactly) and, for the
/// midpoint integrator, also constant: splitting a tet changes the midpoint
/// rule's quadrature (not a stability matter), so with the linear field the
/// midpoint image of the split mesh is only checked for finiteness.
#[test]
fn degenerate_and_sliver_tets_change_nothing() {
    let fields: [(&str, FieldFn); 2] = [("linear", linear_field), ("constant", |_| 0.45)];
    let look = Look::varied(80, 80, 1.5);
    let cams = [
        // Axis-aligned, dyadic: f32 coordinates exact, so zero volume stays exactly zero.
        (
            "axis ortho",
            Cam::ortho([0.0, -20.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 10.0),
        ),
        (
            "oblique ortho",
            Cam::ortho([23.0, 17.0, 11.0], [0.0; 3], [0.0, 0.0, 1.0], 16.0),
        ),
        (
            "oblique persp",
            Cam::persp([23.0, 17.0, 11.0], [0.0; 3], [0.1, 0.0, 1.0], 34.0),
        ),
    ];
    let zero = zero_volume_tets();
    let repeated = |t: &[u32; 4]| (0..4).any(|a| (a + 1..4).any(|b| t[a] == t[b]));
    let mut worst = 0.0f64;
    for (fname, field) in fields {
        let base = cube_mesh(4, [-4.0; 3], 8.0, field);
        let mut with_zero = base.clone();
        with_zero.tets.extend(&zero);
        let mut with_all = with_zero.clone();
        let slivers = add_slivers(&mut with_all, 7, field);
        assert!(slivers >= 40);
        for (name, cam) in &cams {
            let inp_base = input(base.clone(), cam, &look);
            let inp_zero = input(with_zero.clone(), cam, &look);
            let inp_all = input(with_all.clone(), cam, &look);
            let view = inp_base.scene.view();
            let reach: Vec<(bool, bool)> = zero
                .iter()
                .map(|&t| reaches_scan(&view, &with_zero, t))
                .collect();
            let expect_zero = reach.iter().filter(|r| r.0).count() as u64;
            let expect_repeated = zero
                .iter()
                .zip(&reach)
                .filter(|(t, r)| r.0 && repeated(t))
                .count() as u64;
            assert!(
                expect_zero >= 4 && expect_repeated >= 2,
                "{name}: only {expect_zero} zero-volume tets reach scan conversion"
            );
            for integ in INTEGRATORS {
                for order in ORDERS {
                    let o = opts(integ, order);
                    let (ref_img, ref_stats) = render_finite(&inp_base, &o);
                    assert_eq!(
                        ref_stats.cells_degenerate, 0,
                        "{name}: the base mesh has no degenerate cell"
                    );
                    for tile in [16, 32, 64] {
                        let o = CellOptions {
                            tile_size: tile,
                            ..o
                        };
                        let tag = format!("{fname} field, {name} {integ} {order} tile {tile}");
                        let (img, stats) = render_finite(&inp_zero, &o);
                        let ie = img.error_against_rgba(&ref_img);
                        let (e, (i, j)) = (ie.max_abs / 255.0, ie.worst_pixel);
                        assert!(
                            e <= TOL,
                            "{tag}, zero-volume tets added: pixel {:?} got {:?}, want {:?}",
                            ie.worst_pixel,
                            img.get(i, j),
                            ref_img.get(i, j)
                        );
                        if *name == "axis ortho" {
                            assert!(reach.iter().all(|r| r.1), "ambiguous test set-up");
                            assert_eq!(
                                stats.cells_degenerate, expect_zero,
                                "{tag}: cells_degenerate"
                            );
                        } else {
                            // Rounding to f32 may give a coplanar tet a tiny volume; repeated vertices never.
                            assert!(
                                (expect_repeated..=expect_zero).contains(&stats.cells_degenerate),
                                "{tag}: cells_degenerate {} not in {expect_repeated}..={expect_zero}",
                                stats.cells_degenerate
                            );
                        }
                        worst = worst.max(e);
                        let (img, stats) = render_finite(&inp_all, &o);
                        // Slivers are flatter than the renderer's degeneracy
                        // threshold (6 |V| <= 1e-6 |e1||e2||e3|), so they count
                        // too; nothing thicker than twice that may.
                        let flat = thin_tets(&with_all, 2e-6);
                        assert!(
                            stats.cells_degenerate <= flat,
                            "{tag}: {} degenerate, but only {flat} tets ({expect_zero} zero-volume reaching the screen, {slivers} slivers) are that thin",
                            stats.cells_degenerate
                        );
                        if integ == Integrator::Midpoint && fname == "linear" {
                            continue;
                        }
                        let ie = img.error_against_rgba(&ref_img);
                        let (e, (i, j)) = (ie.max_abs / 255.0, ie.worst_pixel);
                        assert!(
                            e <= TOL,
                            "{tag}, slivers added: pixel {:?} got {:?}, want {:?}",
                            ie.worst_pixel,
                            img.get(i, j),
                            ref_img.get(i, j)
                        );
                        worst = worst.max(e);
                    }
                }
            }
            eprintln!("{fname} field, {name}: {expect_zero} zero-volume tets reach scan conversion, {slivers} slivers");
        }
    }
    eprintln!("degenerate and sliver tets: max difference {worst:.2e}");
}

// ------------------------------------------------------ 5. far from origin

#[test]
fn coordinates_offset_by_1e6() {
    let field = |p: [f64; 3]| 0.2 + 0.1 * (p[0] + 3.0) + 0.04 * (p[1] + 3.0) - 0.03 * (p[2] - 3.0);
    let off = 1e6;
    let mesh = cube_mesh(6, [-3.0; 3], 6.0, field);
    let far = cube_mesh(6, [off - 3.0; 3], 6.0, |p| field(p.map(|v| v - off)));
    let look = Look::varied(96, 80, 1.0);
    let cams = [
        (
            "ortho",
            Cam::ortho([23.0, 17.0, 11.0], [0.0; 3], [0.0, 0.0, 1.0], 12.0),
        ),
        (
            "persp",
            Cam::persp([17.0, -13.0, 9.0], [0.3, 0.1, -0.2], [0.0, 0.2, 1.0], 30.0),
        ),
    ];
    let mut worst = 0.0f64;
    for (name, cam) in cams {
        let near_in = input(mesh.clone(), &cam, &look);
        let far_in = input(far.clone(), &cam.shifted([off; 3]), &look);
        for integ in INTEGRATORS {
            for order in ORDERS {
                let o = opts(integ, order);
                let (a, _) = render_finite(&near_in, &o);
                let (b, _) = render_finite(&far_in, &o);
                let ie = b.error_against_rgba(&a);
                let (e, (i, j)) = (ie.max_abs / 255.0, ie.worst_pixel);
                assert!(
                    e <= 2e-4,
                    "{name} {integ} {order}: pixel {:?} far {:?} near {:?}",
                    ie.worst_pixel,
                    b.get(i, j),
                    a.get(i, j)
                );
                assert!(a.pixels.iter().filter(|p| p[3] > 0.1).count() > 1000);
                worst = worst.max(e);
            }
        }
    }
    eprintln!("offset 1e6: max difference {worst:.2e}");
}

// ---------------------------------------------------------- 6. opacity 1

/// Opacity 1 everywhere (clamped to 1 - 1e-6: extinction 13.8 per unit) over
/// chords up to 69 units: alpha saturates, colours stay finite and in [0, 1].
///
/// Against the analytic image the tolerance is 1e-4 plus what a depth error
/// of `DEPTH_REL` times the eye distance does to alpha (`dA/dL = tau (1 - A)`):
/// with this extinction, a chord 1e-4 units short near the silhouette changes
/// alpha by up to 1.4e-3, and f32 depths around 150 are only good to ~1e-5
/// each. The measured chord error is reported.
#[test]
fn opacity_one_saturates_without_overflow() {
    const DEPTH_REL: f64 = 2e-6;
    let mesh = cube_mesh(8, [-20.0; 3], 40.0, |_| 0.5);
    let (lo, hi) = ([-20.0; 3], [20.0; 3]);
    let eye = [90.0, 70.0, 50.0];
    let far = (90f64.powi(2) + 70f64.powi(2) + 50f64.powi(2)).sqrt() + 20.0 * 3f64.sqrt();
    let tau = -(1e-6f64).ln();
    let cams = [
        ("ortho", Cam::ortho(eye, [0.0; 3], [0.0, 0.0, 1.0], 80.0)),
        ("persp", Cam::persp(eye, [0.0; 3], [0.0, 0.0, 1.0], 40.0)),
    ];
    let mut worst_chord = 0.0f64;
    for (rgb, bg) in [
        ([1.0, 1.0, 1.0], [1.0, 1.0, 1.0]),
        ([1.0, 0.5, 0.0], [0.0, 0.0, 0.0]),
    ] {
        let mut look = Look::constant(90, 90, rgb, 1.0, 1.0);
        look.background = bg;
        for (name, cam) in &cams {
            let inp = input(mesh.clone(), cam, &look);
            let want = analytic_box_image(&inp.scene, &look, lo, hi);
            let long = covered(&inp.scene, lo, hi, 1.0);
            assert!(long.iter().filter(|&&c| c).count() > 2000);
            for integ in INTEGRATORS {
                for order in ORDERS {
                    let tag = format!("opacity 1 {name} {integ} {order} rgb {rgb:?}");
                    let (img, _) = render_finite(&inp, &opts(integ, order));
                    for (k, p) in img.pixels.iter().enumerate() {
                        assert!(
                            p.iter().all(|&v| (0.0..=1.0).contains(&v)),
                            "{tag}: pixel {k} = {p:?} outside [0, 1]"
                        );
                        if long[k] {
                            assert!(
                                p[3] >= 1.0 - 1e-5,
                                "{tag}: pixel {k} alpha {} after a chord >= 1 unit",
                                p[3]
                            );
                            for c in 0..3 {
                                assert!(
                                    (p[c] as f64 - rgb[c]).abs() <= 1e-5,
                                    "{tag}: pixel {k} = {p:?}"
                                );
                            }
                        }
                        let w = want[k];
                        let tol = 1e-4 + tau * (1.0 - w[3]) * DEPTH_REL * far;
                        for c in 0..4 {
                            assert!(
                                (p[c] as f64 - w[c]).abs() <= tol,
                                "{tag}: pixel {k} = {p:?}, want {w:?} (tolerance {tol:e})"
                            );
                        }
                        let (ag, aw) = (p[3] as f64, w[3]);
                        // Below 0.99, where f32 alpha still resolves the chord well.
                        if ag < 0.99 && aw < 0.99 {
                            worst_chord =
                                worst_chord.max(((1.0 - ag).ln() - (1.0 - aw).ln()).abs() / tau);
                        }
                    }
                }
            }
        }
    }
    eprintln!("opacity 1: worst chord error implied by alpha {worst_chord:.2e} units (depths up to {far:.0})");
}

// --------------------------------------------------- 7. zero-length segments

/// Lattice points `5 (x, y, z)`, `|x|, |y|, |z| <= 3`, that project onto pixel
/// centres in [`rational_cam`] with `pixel_size = 0.5`.
fn centre_points() -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for x in -3i32..=3 {
        for y in -3i32..=3 {
            for z in -3i32..=3 {
                if (3 * x + 4 * y + 12 * z).rem_euclid(13) == 0 {
                    out.push([5.0 * x as f64, 5.0 * y as f64, 5.0 * z as f64]);
                }
            }
        }
    }
    out
}

fn volume(v: [[f64; 3]; 4]) -> f64 {
    let e = |k: usize| [v[k][0] - v[0][0], v[k][1] - v[0][1], v[k][2] - v[0][2]];
    let (a, b, c) = (e(1), e(2), e(3));
    (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0]))
        / 6.0
}

/// Single tets all of whose vertices lie exactly on pixel-centre rays: the
/// rays through the silhouette vertices (and along silhouette edges through
/// pixel centres) only graze the tet, giving zero-length or no segments.
#[test]
fn grazing_rays_through_vertices_and_edges() {
    let pts = centre_points();
    let o = [0.0; 3];
    // Tets with a vertex at the origin and three more lattice points on pixel
    // centres, reasonably shaped; a handful of them.
    let mut tets = Vec::new();
    'outer: for (ia, a) in pts.iter().enumerate() {
        for (ib, b) in pts.iter().enumerate().skip(ia + 1) {
            for c in pts.iter().skip(ib + 1) {
                let v = [o, *a, *b, *c];
                let vol = volume(v).abs();
                let edges = [a, b, c]
                    .iter()
                    .map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt())
                    .fold(0.0, f64::max);
                if vol > 0.05 * edges.powi(3) && edges < 30.0 {
                    tets.push(v);
                    if tets.len() == 6 {
                        break 'outer;
                    }
                }
            }
        }
    }
    assert_eq!(tets.len(), 6, "{} pixel-centre points", pts.len());
    let (w, h) = (121, 121);
    let look = Look::constant(w, h, [0.9, 0.5, 0.2], 0.3, 8.0);
    let cam = rational_cam(o, 0.5, h);
    let mut worst = 0.0f64;
    for v in tets {
        let mesh = TetMesh {
            points: v.to_vec(),
            tets: vec![[0, 1, 2, 3]],
            fields: vec![pvrsim::data::Field {
                name: FIELD.into(),
                components: 1,
                values: vec![0.5; 4],
            }],
        };
        let inp = input(mesh, &cam, &look);
        let view = inp.scene.view();
        for p in v {
            let q = view.camera_to_pixel(view.to_camera(p)).unwrap();
            assert!(
                q.iter().all(|&x| (x - x.floor() - 0.5).abs() < 1e-9),
                "{p:?} -> {q:?}"
            );
        }
        let want = analytic_tet_image(&inp.scene, &look, v);
        for integ in INTEGRATORS {
            let (img, _) = render_finite(&inp, &opts(integ, CellOrder::Stored));
            worst = worst.max(assert_analytic(
                &format!("tet {v:?} {integ}"),
                &img,
                &want,
                TOL,
            ));
        }
    }
    eprintln!("grazing single tets: max error {worst:.2e}");
}

/// A 6 x 6 grid of points `pt(a, b)` and tets of four of them each: the four
/// corners of each grid square, and (`diagonal`) tets with the points
/// `(i, j), (i + 1, j + 1)` and the grid's corners `(0, 0), (5, 5)` — four
/// points on one line when `i = j`, so only those with `i != j` unless
/// `collinear`.
fn flat_mesh(pt: &dyn Fn(f64, f64) -> [f64; 3], collinear: bool) -> TetMesh {
    let mut points = Vec::new();
    for j in 0..6 {
        for i in 0..6 {
            points.push(pt(i as f64 - 2.5, j as f64 - 2.5));
        }
    }
    let v = |i: u32, j: u32| j * 6 + i;
    let mut tets = Vec::new();
    for j in 0..5 {
        for i in 0..5 {
            tets.push([v(i, j), v(i + 1, j), v(i, j + 1), v(i + 1, j + 1)]);
            if i != j || collinear {
                tets.push([v(i, j), v(i + 1, j + 1), v(0, 0), v(5, 5)]);
            }
        }
    }
    let values = points.iter().map(|p| 0.5 + 0.01 * p[0]).collect();
    TetMesh {
        points,
        tets,
        fields: vec![pvrsim::data::Field {
            name: FIELD.into(),
            components: 1,
            values,
        }],
    }
}

/// Renders `mesh` with every integrator and order and checks it is the
/// background within `TOL`; returns the largest deviation.
fn check_background(name: &str, mesh: &TetMesh, cam: &Cam, look: &Look) -> f64 {
    let bg = look.background;
    let inp = input(mesh.clone(), cam, look);
    let mut worst = 0.0f64;
    for integ in INTEGRATORS {
        for order in ORDERS {
            let (img, stats) = render_finite(&inp, &opts(integ, order));
            let (e, k) = max_err(&img, &vec![[bg[0], bg[1], bg[2], 0.0]; img.pixels.len()]);
            let (i, j) = (k as u32 % img.width, k as u32 / img.width);
            assert!(
                e <= TOL,
                "{name} {integ} {order}: pixel ({i}, {j}) = {:?}, background {bg:?}; {stats:?}",
                img.pixels[k]
            );
            worst = worst.max(e);
        }
    }
    worst
}

const FLAT_EYE: [f64; 3] = [23.0, 17.0, 11.0];

/// A mesh whose points all lie in one plane has no volume: it renders as the
/// background — a plane seen obliquely (f32 rounding leaves its tets slivers
/// of volume, whose chords are rounding-sized), and a plane containing the
/// view direction that projects onto a row of pixel centres (exactly
/// degenerate in f32).
#[test]
fn flat_mesh_renders_as_background() {
    let look = Look::constant(61, 61, [0.9, 0.5, 0.2], 0.5, 0.5);
    let horizontal = flat_mesh(&|a, b| [3.0 * a, 3.0 * b, 0.3], false);
    let (r, f) = ([0.8, -0.6, 0.0], [3.0 / 13.0, 4.0 / 13.0, 12.0 / 13.0]);
    let edge_on = flat_mesh(
        &|a, b| {
            [
                3.0 * a * r[0] + 3.0 * b * f[0],
                3.0 * a * r[1] + 3.0 * b * f[1],
                3.0 * b * f[2],
            ]
        },
        false,
    );
    let mut worst = 0.0f64;
    worst = worst.max(check_background(
        "horizontal ortho",
        &horizontal,
        &Cam::ortho(FLAT_EYE, [0.0; 3], [0.0, 0.0, 1.0], 20.0),
        &look,
    ));
    worst = worst.max(check_background(
        "horizontal persp",
        &horizontal,
        &Cam::persp(FLAT_EYE, [0.0; 3], [0.0, 0.0, 1.0], 40.0),
        &look,
    ));
    let cam = rational_cam([0.0; 3], 0.5, 61);
    let e = check_background("edge-on ortho", &edge_on, &cam, &look);
    assert!(
        e <= 1e-7,
        "exactly degenerate in f32: the background up to its rounding to f32, got {e:e}"
    );
    let (_, stats) = cell::render(&input(edge_on, &cam, &look), &CellOptions::default());
    assert!(
        stats.cells_degenerate > 0,
        "the flat tets reach scan conversion as degenerate: {stats:?}"
    );
    eprintln!("flat mesh: largest deviation from the background {worst:.2e}");
}

/// Tets whose four points lie on one line (a zero-volume "needle"), in the
/// same oblique plane: still no volume, so still the background.
///
/// Open bug. Failing case: points `(3 (i - 2.5), 3 (j - 2.5), 0.3)` of the
/// 6 x 6 grid, tet `[(2,2), (3,3), (0,0), (5,5)]` (four points on the
/// diagonal), orthographic, eye `(23, 17, 11)`, target 0, up `+z`, height 20,
/// 61 x 61: expected the background everywhere (alpha 0); got, for that tet
/// alone, 101 pixels with alpha > 1e-3 and up to 0.99971 (with the whole mesh
/// of this test, pixel (34, 40) has alpha 0.99979). Cause: rounded to f32 screen
/// space the four points are no longer exactly collinear, so `setup_tet`
/// (which only rejects exactly zero volume) accepts the tet, but every face
/// normal is rounding noise (|n| ~ 1e-5 where a real face of that size has
/// ~1e2), so the four half-spaces point in arbitrary directions and their
/// intersection spans many pixels and the tet's whole depth range. Coplanar
/// tets without three collinear points are fine (previous test). A fix needs
/// a degeneracy threshold relative to the f32 rounding of the coordinates
/// (e.g. reject a face whose height is below a few ulps of its coordinates),
/// which changes which thin cells are drawn, so it is not done here.
#[test]
fn collinear_tets_render_as_background() {
    let look = Look::constant(61, 61, [0.9, 0.5, 0.2], 0.5, 0.5);
    let mesh = flat_mesh(&|a, b| [3.0 * a, 3.0 * b, 0.3], true);
    check_background(
        "collinear ortho",
        &mesh,
        &Cam::ortho(FLAT_EYE, [0.0; 3], [0.0, 0.0, 1.0], 20.0),
        &look,
    );
    check_background(
        "collinear persp",
        &mesh,
        &Cam::persp(FLAT_EYE, [0.0; 3], [0.0, 0.0, 1.0], 40.0),
        &look,
    );
}

// -------------------------------------------- 8. thread and tile independence

fn render_in_pool(threads: usize, input: &RenderInput, o: &CellOptions) -> Image {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let (img, stats) = pool.install(|| cell::render(input, o));
    assert_eq!(stats.threads, threads);
    assert!(!img.has_non_finite());
    img
}

#[test]
fn thread_count_and_tile_size_do_not_change_a_bit() {
    let input = demo_input();
    for integ in INTEGRATORS {
        for order in ORDERS {
            let base = opts(integ, order);
            let reference = render_in_pool(1, input, &base);
            assert!(
                reference.pixels.iter().filter(|p| p[3] > 0.05).count() > 5000,
                "demo image is mostly empty"
            );
            for threads in [1, 2] {
                for tile in [16, 32, 64] {
                    let img = render_in_pool(
                        threads,
                        input,
                        &CellOptions {
                            tile_size: tile,
                            ..base
                        },
                    );
                    let diff = img
                        .pixels
                        .iter()
                        .zip(&reference.pixels)
                        .filter(|(a, b)| a.map(f32::to_bits) != b.map(f32::to_bits))
                        .count();
                    assert!(diff == 0, "{integ} {order}: {threads} threads, tile {tile}: {diff} pixels differ from 1 thread, tile 32");
                }
            }
        }
    }
}
