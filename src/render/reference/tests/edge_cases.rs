//! Edge cases and invariants of the reference renderer: the background under
//! the volume, opacity 1 clamped, a 1e6 offset, zero-volume and sliver
//! tets, thread count, the tolerance's effect, empty meshes and missed rays.

use super::support::*;
use crate::data::TetMesh;

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
