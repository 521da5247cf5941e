//! slice3d against the grid reference, and the invariants of its options.

use std::sync::Arc;

use super::*;
use crate::render::grid_reference::tests::{scene, volume};
use crate::render::{grid_reference, VolumeInput};

/// A smooth blob (a sum of two Gaussians) on a 24 x 20 x 16 grid, u8, seen
/// obliquely; TF with a transparent low end (so blocks get skipped).
pub(crate) fn blob(projection: &str) -> VolumeInput {
    blob_tf(
        projection,
        "unit_distance = 2\npoints = [[0, 0, 0, 0, 0], [0.15, 0.2, 0.3, 1, 0], [0.5, 1, 0.6, 0.2, 0.15], [1, 1, 1, 1, 0.6]]",
    )
}

/// The blob with another transfer function.
pub(crate) fn blob_tf(projection: &str, transfer: &str) -> VolumeInput {
    let v = volume([24, 20, 16], [1.0, 1.2, 1.5], [-11.5, -11.4, -11.25], |p| {
        let g = |c: [f64; 3], r: f64| {
            (-((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)) / (r * r))
                .exp()
        };
        (200.0 * g([2.0, 1.0, 0.0], 6.0) + 120.0 * g([-5.0, -3.0, 2.0], 4.0)).round() as f32
    });
    let u8v = match &v.voxels {
        crate::data::Voxels::F32(x) => x.iter().map(|&s| s as u8).collect(),
        _ => unreachable!(),
    };
    let v = crate::data::Volume::new(
        std::path::Path::new("blob"),
        v.dims,
        v.spacing,
        v.origin,
        "s",
        crate::data::Voxels::U8(u8v),
    )
    .unwrap();
    let sc = scene(projection, transfer, 48, Some([0.0, 255.0]));
    VolumeInput::new(sc, Arc::new(v)).unwrap()
}

const ORTHO: &str = "eye = [30, -20, 25]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\nprojection = \"orthographic\"\nheight = 34";
const PERSP: &str = "eye = [30, -20, 25]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\nprojection = \"perspective\"\nfov_y_deg = 45";

#[test]
fn close_to_the_reference_at_the_default_spacing() {
    for cam in [ORTHO, PERSP] {
        let inp = blob(cam);
        let (r, _) = grid_reference::render(&inp, &Default::default());
        let (img, st) = render(&inp, &Default::default()).unwrap();
        let e = img.error_against(&r);
        // One slice per voxel layer crossed: more than the largest
        // dimension (24) for this oblique view.
        assert!(st.samples_taken > 0 && st.slices > 24, "{st:?}");
        assert!(e.rmse <= 1.0 && e.max_abs <= 8.0, "{cam}: {e}");
        // Finer slices converge towards the reference.
        let fine = Slice3dOptions {
            slices: SliceCount::Count(8 * st.slices),
            ..Default::default()
        };
        let (img2, _) = render(&inp, &fine).unwrap();
        let e2 = img2.error_against(&r);
        assert!(e2.rmse < 0.5 * e.rmse, "{cam}: {e2} vs {e}");
    }
}

#[test]
fn empty_space_skipping_changes_nothing() {
    for (cam, classify) in [ORTHO, PERSP]
        .into_iter()
        .flat_map(|c| [(c, Classify::Preint), (c, Classify::Post)])
    {
        let inp = blob(cam);
        for order in [Order::FrontToBack, Order::BackToFront] {
            let on = Slice3dOptions {
                order,
                classify,
                ..Default::default()
            };
            let off = Slice3dOptions {
                empty_skip: false,
                ..on
            };
            let (a, sa) = render(&inp, &on).unwrap();
            let (b, sb) = render(&inp, &off).unwrap();
            assert_eq!(a, b);
            assert!(sa.samples_skipped_empty > 0, "{sa:?}");
            assert_eq!(sb.samples_skipped_empty, 0);
            if order == Order::BackToFront {
                assert_eq!(
                    sa.samples_taken + sa.samples_skipped_empty,
                    sb.samples_taken
                );
            }
        }
    }
}

#[test]
fn back_to_front_equals_front_to_back_without_ert() {
    let inp = blob(PERSP);
    let ftb = Slice3dOptions {
        ert: 1.0,
        ..Default::default()
    };
    let btf = Slice3dOptions {
        order: Order::BackToFront,
        ..ftb
    };
    let (a, _) = render(&inp, &ftb).unwrap();
    let (b, _) = render(&inp, &btf).unwrap();
    let e = a.error_against(&b);
    assert!(e.max_abs < 0.01, "{e}");
}

#[test]
fn ert_stays_within_its_bound_and_skips() {
    let inp = blob(ORTHO);
    let off = Slice3dOptions {
        ert: 1.0,
        ..Default::default()
    };
    let on = Slice3dOptions {
        ert: 0.3,
        ..Default::default()
    };
    let (a, _) = render(&inp, &off).unwrap();
    let (b, sb) = render(&inp, &on).unwrap();
    assert!(sb.samples_skipped_ert > 0);
    let e = a.error_against(&b);
    assert!(
        e.max_abs / 255.0 <= sb.ert_error_bound + 1e-6,
        "{e} bound {}",
        sb.ert_error_bound
    );
}

#[test]
fn pre_classification_is_close_but_not_identical() {
    let inp = blob(ORTHO);
    let (r, _) = grid_reference::render(&inp, &Default::default());
    let pre = Slice3dOptions {
        classify: Classify::Pre,
        ..Default::default()
    };
    let (a, st) = render(&inp, &pre).unwrap();
    let (b, _) = render(&inp, &Default::default()).unwrap();
    assert_eq!(st.texture_bytes, 4 * inp.volume.len());
    assert_ne!(a, b);
    let e = a.error_against(&r);
    assert!(e.rmse < 4.0, "{e}");
}

#[test]
fn threads_do_not_change_the_image() {
    let inp = blob(PERSP);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let (a, _) = one.install(|| render(&inp, &Default::default())).unwrap();
    let (b, _) = render(&inp, &Default::default()).unwrap();
    assert_eq!(a, b);
}

#[test]
fn bad_options_are_refused() {
    let inp = blob(ORTHO);
    for o in [
        Slice3dOptions {
            ert: 0.0,
            ..Default::default()
        },
        Slice3dOptions {
            slices: SliceCount::Count(0),
            ..Default::default()
        },
        Slice3dOptions {
            slices: SliceCount::Spacing(-1.0),
            ..Default::default()
        },
    ] {
        assert!(render(&inp, &o).is_err());
    }
}

// The pre-integration tests (constant field, steep TF) are in
// tests/slice3d_preint.rs.
