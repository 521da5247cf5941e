//! slice2d against the grid reference; LOD memory and image; the 45° jump.

use super::*;
use crate::render::grid_reference;
use crate::render::slice3d::tests::{blob, blob_tf};

const ORTHO: &str = "eye = [30, -20, 25]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\nprojection = \"orthographic\"\nheight = 34";
const PERSP: &str = "eye = [30, -20, 25]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\nprojection = \"perspective\"\nfov_y_deg = 45";

#[test]
fn close_to_the_reference_and_reports_its_error() {
    for cam in [ORTHO, PERSP] {
        let inp = blob(cam);
        let (r, _) = grid_reference::render(&inp, &Default::default());
        let (img, st) = render(&inp, &Default::default()).unwrap();
        let e = img.error_against(&r);
        println!("slice2d {cam:?}: {e}");
        assert!(st.samples_taken > 0);
        assert_eq!(st.slicing_axis, Some(0), "{st:?}");
        assert!(e.rmse <= 3.0 && e.max_abs <= 24.0, "{e}");
    }
}

#[test]
fn lod_reduces_memory_and_a_far_plane_changes_nothing() {
    let inp = blob(PERSP);
    let (full, sf) = render(&inp, &Default::default()).unwrap();
    // D beyond every slice: all at level 0, same image.
    let far = Slice2dOptions {
        lod: Some(1e6),
        ..Default::default()
    };
    let (same, ss) = render(&inp, &far).unwrap();
    assert_eq!(full, same);
    assert_eq!(sf.texture_bytes, ss.texture_bytes);
    // D of a tenth of the eye distance: levels >= 3, far less memory.
    let near = Slice2dOptions {
        lod: Some(4.0),
        ..Default::default()
    };
    let (img, sn) = render(&inp, &near).unwrap();
    assert!(sn.texture_bytes * 4 < sf.texture_bytes, "{sn:?} vs {sf:?}");
    assert!(sn.slices_per_level.as_ref().unwrap().len() > 2);
    assert_ne!(img, full);
}

/// Turning the camera about z from 44.8° to 45.2° off the x axis switches
/// the slicing axis from x to y: the slice2d image jumps (its samples move
/// to other planes) far more than the reference image or the slice3d image
/// changes. A thin iso-shell TF makes the sampling visible.
#[test]
fn the_45_degree_axis_switch_jumps() {
    let cam = |deg: f64| {
        let (s, c) = deg.to_radians().sin_cos();
        format!(
            "eye = [{}, {}, 8]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\nprojection = \"orthographic\"\nheight = 34",
            40.0 * c,
            40.0 * s
        )
    };
    let tf = "unit_distance = 1\npoints = [[0, 1, 1, 1, 0], [0.45, 1, 1, 1, 0], [0.5, 1, 0.8, 0.3, 0.9], [0.55, 1, 1, 1, 0], [1, 1, 1, 1, 0]]";
    let (a, b) = (blob_tf(&cam(44.8), tf), blob_tf(&cam(45.2), tf));
    assert_eq!(slicing_axis(&a), 0);
    assert_eq!(slicing_axis(&b), 1);
    let (ra, _) = grid_reference::render(&a, &Default::default());
    let (rb, _) = grid_reference::render(&b, &Default::default());
    let (sa, _) = render(&a, &Default::default()).unwrap();
    let (sb, _) = render(&b, &Default::default()).unwrap();
    let (ta, _) = crate::render::slice3d::render(&a, &Default::default()).unwrap();
    let (tb, _) = crate::render::slice3d::render(&b, &Default::default()).unwrap();
    let d_ref = ra.error_against(&rb).rmse;
    let d_2d = sa.error_against(&sb).rmse;
    let d_3d = ta.error_against(&tb).rmse;
    println!(
        "44.8 -> 45.2 degrees: reference changes by RMSE {d_ref:.3}/255, slice3d by {d_3d:.3}/255, \
         slice2d by {d_2d:.3}/255 (max {:.2}/255)",
        sa.error_against(&sb).max_abs
    );
    assert!(
        d_2d > 2.0 * d_ref && d_2d > 2.0 * d_3d,
        "{d_2d} vs {d_ref}, {d_3d}"
    );
}

#[test]
fn slice2d_refuses_preint() {
    let inp = blob(ORTHO);
    let o = Slice2dOptions {
        classify: Classify::Preint,
        ..Default::default()
    };
    let e = render(&inp, &o).unwrap_err();
    assert!(e.to_string().contains("preint"), "{e}");
}
