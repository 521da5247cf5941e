//! Images against exact answers: closed forms for a constant field in one
//! tet, the independent 1D integral for linear fields over cubes, rings and
//! jittered grids, with rays through vertices, along edges and in faces,
//! orthographic and perspective (eye inside the mesh too).

use super::support::*;
use crate::data::TetMesh;

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
