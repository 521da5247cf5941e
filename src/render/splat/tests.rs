//! Tests of the splatting renderer against closed forms: the opacity
//! contract on a constant field (orthographic and perspective), culling,
//! and order agreement.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::order::Order;
use super::{render_splat, SplatOptions};
use crate::data::{Volume, Voxels};
use crate::render::VolumeInput;
use crate::scene::camera::{Camera, Projection};
use crate::scene::{DataSpec, ImageSpec, Scene, TransferFunction};

/// An `n^3` u8 volume of constant value `v`, spacing 1, origin 0.
fn constant(n: u64, v: u8) -> Arc<Volume> {
    Arc::new(
        Volume::new(
            Path::new("const"),
            [n; 3],
            [1.0; 3],
            [0.0; 3],
            "s",
            Voxels::U8(vec![v; (n * n * n) as usize]),
        )
        .unwrap(),
    )
}

fn input(vol: Arc<Volume>, projection: Projection, eye_dist: f64, opacity: f64) -> VolumeInput {
    let c = (vol.dims[0] - 1) as f64 * 0.5;
    let scene = Scene {
        data: DataSpec {
            path: PathBuf::from("const"),
            field: "s".into(),
            range: Some([0.0, 255.0]),
        },
        camera: Camera {
            eye: [c, c, c + eye_dist],
            target: [c, c, c],
            up: [0.0, 1.0, 0.0],
            projection,
        },
        image: ImageSpec {
            width: 41,
            height: 41,
            background: [0.0; 3],
        },
        transfer: TransferFunction::from_rows(
            &[
                [0.0, 1.0, 1.0, 1.0, 0.0],
                [0.5, 1.0, 0.5, 0.25, opacity],
                [1.0, 1.0, 0.5, 0.25, opacity],
            ],
            1.0,
        ),
    };
    VolumeInput::new(scene, vol).unwrap()
}

/// A constant field of extinction tau seen along z: the centre pixel's
/// alpha is `1 - exp(-tau n)` (each of the n samples holds one voxel of
/// extent) and its colour is the TF colour times alpha.
#[test]
fn constant_field_matches_the_slab_integral() {
    let n = 24;
    let o = 0.05;
    let tau = -(1.0f64 - o).ln();
    let want = 1.0 - (-tau * n as f64).exp();
    for (proj, dist) in [
        (Projection::Orthographic { height: 30.0 }, 100.0),
        // Far away and narrow: nearly parallel rays through the centre.
        (Projection::Perspective { fov_y_deg: 0.5 }, 3000.0),
    ] {
        for order in Order::ALL {
            let inp = input(constant(n, 255), proj, dist, o);
            let (img, st) = render_splat(
                &inp,
                &SplatOptions {
                    order,
                    ..Default::default()
                },
            )
            .unwrap();
            assert_eq!(st.voxels_drawn, n * n * n, "{order}");
            let p = img.get(20, 20);
            assert!(
                (p[3] as f64 - want).abs() < 0.01,
                "{order} {proj:?}: alpha {} want {want}",
                p[3]
            );
            assert!(
                (p[1] as f64 - 0.5 * want).abs() < 0.01,
                "{order}: green {}",
                p[1]
            );
            assert!(!img.has_non_finite());
        }
    }
}

#[test]
fn transparent_voxels_are_never_drawn() {
    let inp = input(
        constant(8, 0),
        Projection::Orthographic { height: 12.0 },
        50.0,
        0.3,
    );
    for order in Order::ALL {
        let (img, st) = render_splat(
            &inp,
            &SplatOptions {
                order,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(st.voxels_drawn, 0);
        assert_eq!(st.voxels_culled_transparent, 512);
        assert_eq!(st.fill_rate, 0.0);
        assert!(img.pixels.iter().all(|p| p[3] == 0.0));
    }
}

/// DDA and the sorts draw a non-trivial volume nearly identically.
#[test]
fn dda_and_sort_agree() {
    let n = 16u64;
    let v: Vec<u8> = (0..n * n * n)
        .map(|i| ((i * 2654435761) % 251) as u8)
        .collect();
    let vol = Arc::new(
        Volume::new(
            Path::new("noise"),
            [n; 3],
            [1.0; 3],
            [0.0; 3],
            "s",
            Voxels::U8(v),
        )
        .unwrap(),
    );
    let mut inp = input(vol, Projection::Orthographic { height: 30.0 }, 60.0, 0.4);
    inp.scene.camera.eye = [40.0, -25.0, 50.0];
    let render = |order| {
        render_splat(
            &inp,
            &SplatOptions {
                order,
                ..Default::default()
            },
        )
        .unwrap()
        .0
    };
    let q = render(Order::Quicksort);
    let e = render(Order::Dda).error_against(&q);
    assert!(e.rmse < 1.0 && e.max_abs < 12.0, "dda vs quicksort: {e}");
    let r = render(Order::Radix).error_against(&q);
    assert!(r.max_abs < 1.0, "radix vs quicksort: {r}");
}

/// The pre-pass path draws the same image as the full walk, bit for bit
/// (same order, same per-splat arithmetic), for every order, orthographic
/// and perspective; the incremental footprints stay within f32 rounding of
/// the exact ones; the footprint table within a small error (orthographic
/// only: perspective views ignore it and stay exact).
#[test]
fn prepass_is_exact_and_fast_footprints_are_close() {
    let n = 20u64;
    let v: Vec<u8> = (0..n * n * n)
        .map(|i| {
            let (x, y, z) = (i % n, i / n % n, i / (n * n));
            let r2 = [x, y, z]
                .iter()
                .map(|&c| (c as f64 - 9.5).powi(2))
                .sum::<f64>();
            // A blob with holes: about a third of the voxels drawn.
            if r2 < 60.0 && (x + 2 * y + 3 * z) % 5 != 0 {
                (255.0 - 3.0 * r2) as u8
            } else {
                0
            }
        })
        .collect();
    let vol = Arc::new(
        Volume::new(
            Path::new("blob"),
            [n; 3],
            [1.0; 3],
            [0.0; 3],
            "s",
            Voxels::U8(v),
        )
        .unwrap(),
    );
    for (proj, dist) in [
        (Projection::Orthographic { height: 34.0 }, 60.0),
        (Projection::Perspective { fov_y_deg: 40.0 }, 40.0),
    ] {
        let mut inp = input(vol.clone(), proj, dist, 0.4);
        inp.scene.camera.eye = [9.5 + 0.6 * dist, 9.5 - 0.5 * dist, 9.5 + 0.62 * dist];
        for order in Order::ALL {
            let run = |sparse, incremental, table_phases| {
                render_splat(
                    &inp,
                    &SplatOptions {
                        order,
                        sparse,
                        incremental,
                        table_phases,
                        ..Default::default()
                    },
                )
                .unwrap()
            };
            let (full, sf) = run(false, false, 0);
            let (pre, sp) = run(true, false, 0);
            assert_eq!(sf.voxels_drawn, sp.voxels_drawn, "{order}");
            assert!(sf.voxels_drawn > 500, "{order}: {}", sf.voxels_drawn);
            let e = pre.error_against(&full);
            assert_eq!(
                e.max_abs, 0.0,
                "{order} {proj:?}: pre-pass changed the image: {e}"
            );
            let (inc, _) = run(true, true, 0);
            let e = inc.error_against(&full);
            // Up to f32 rounding, and a pixel exactly at the cut may flip.
            assert!(
                e.max_abs < 1.0 && e.rmse < 0.05,
                "{order} {proj:?}: incremental {e}"
            );
            let (tab, st) = run(true, true, 8);
            let e = tab.error_against(&full);
            if matches!(proj, Projection::Orthographic { .. }) {
                assert_eq!(st.table_phases, 8);
                assert!(
                    e.max_abs > 0.0 && e.max_abs < 3.0 && e.rmse < 0.5,
                    "{order}: table {e}"
                );
            } else {
                assert_eq!(st.table_phases, 0);
                assert!(
                    e.max_abs < 1.0,
                    "{order}: perspective ignores the table: {e}"
                );
            }
        }
    }
}

/// Early splat elimination (front to back, occlusion tiles): a threshold
/// next to 1 skips nothing and gives the back-to-front (`ert = 1`) image to
/// f32 rounding; thresholds 0.99 / 0.9 / 0.5 skip splats and stay within
/// the stated bound `(1 - t) max(radiance, background)` of that image, for
/// every order, orthographic and perspective, over a coloured background.
#[test]
fn early_splat_elimination_stays_within_its_bound() {
    let n = 24u64;
    for (proj, dist) in [
        (Projection::Orthographic { height: 30.0 }, 100.0),
        (Projection::Perspective { fov_y_deg: 40.0 }, 45.0),
    ] {
        // Opacity 0.3 per voxel: most rays reach A = 0.99 inside the cube.
        let mut inp = input(constant(n, 255), proj, dist, 0.3);
        inp.scene.camera.eye = [11.5 + 0.5 * dist, 11.5 - 0.4 * dist, 11.5 + 0.77 * dist];
        inp.scene.image.background = [0.2, 0.9, 0.4];
        for order in Order::ALL {
            let run = |ert| {
                render_splat(
                    &inp,
                    &SplatOptions {
                        order,
                        ert,
                        ..Default::default()
                    },
                )
                .unwrap()
            };
            let (exact, se) = run(1.0);
            assert_eq!(se.ert_threshold, 1.0);
            assert_eq!((se.pieces_skipped_ert, se.ert_error_bound), (0, 0.0));
            assert!(se.pieces >= se.voxels_drawn, "{order}");
            let (near, sn) = run(0.999_999);
            assert_eq!(sn.pieces_skipped_ert, 0, "{order}");
            let e = near.error_against(&exact);
            assert!(e.max_abs < 0.01, "{order} {proj:?}: front to back {e}");
            for t in [0.99f32, 0.9, 0.5] {
                let (img, st) = run(t);
                // M = max(TF radiance 1.0, background 0.9).
                let bound = (1.0 - t as f64) * 1.0;
                assert!((st.ert_error_bound - bound).abs() < 1e-6);
                assert!(
                    st.pieces_skipped_ert * 10 > st.pieces,
                    "{order} {proj:?} t {t}: only {} of {} skipped",
                    st.pieces_skipped_ert,
                    st.pieces
                );
                let e = img.error_against(&exact);
                assert!(
                    e.max_abs <= 255.0 * bound + 1e-3,
                    "{order} {proj:?} t {t}: {e} over the bound {}",
                    255.0 * bound
                );
                assert!(!img.has_non_finite());
            }
        }
    }
}
