//! The shear-warp renderer (issue 22, `--renderer shearwarp`):
//!
//! - its error against the f64 grid reference on bundled and generated
//!   orthographic scenes (RMSE below VolPack's 1.8/255 level, and a
//!   max-abs bound measured here);
//! - skipping the transparent runs of the RLE is exact (property test:
//!   the image with skipping equals the one visiting every cell, bit for
//!   bit);
//! - the principal axis for all six signs of the view direction;
//! - a perspective scene is refused with an error naming the projection.

use std::path::Path;
use std::sync::Arc;

use proptest::prelude::*;
use pvrsim::data::{Volume, Voxels};
use pvrsim::render::shearwarp::factor::Factor;
use pvrsim::render::shearwarp::{self, ShearWarpOptions};
use pvrsim::render::{grid_reference, VolumeInput};
use pvrsim::scene::Scene;

mod phantom;
use phantom::head_phantom;

#[allow(clippy::too_many_arguments)] // a test helper: one argument per scene key
/// A scene over volume `vol` (centred on `centre`, extent `ext`) seen from
/// direction `dir` (eye - target), orthographic, `size`^2 pixels.
fn scene(
    path: &str,
    field: &str,
    centre: [f64; 3],
    ext: f64,
    dir: [f64; 3],
    up: [f64; 3],
    projection: &str,
    size: u32,
    tf: &str,
) -> Scene {
    let l = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let e: Vec<f64> = (0..3).map(|a| centre[a] + 2.0 * ext * dir[a] / l).collect();
    Scene::parse(
        &format!(
            r#"
[data]
path = "{path}"
field = "{field}"
range = [0, 255]
[camera]
eye = [{}, {}, {}]
target = [{}, {}, {}]
up = [{}, {}, {}]
{projection}
[image]
width = {size}
height = {size}
background = [0.1, 0.05, 0]
[transfer]
unit_distance = 1
points = {tf}
"#,
            e[0], e[1], e[2], centre[0], centre[1], centre[2], up[0], up[1], up[2],
        ),
        Path::new("shearwarp-test.toml"),
    )
    .unwrap()
}

const PHANTOM_TF: &str =
    "[[0.0, 0, 0, 0, 0], [0.16, 0.9, 0.7, 0.6, 0], [0.27, 0.95, 0.75, 0.65, 0.04], \
     [0.38, 0.9, 0.7, 0.6, 0], [0.6, 0.8, 0.8, 0.9, 0], [0.8, 1.0, 0.95, 0.85, 0.9], \
     [1.0, 1.0, 1.0, 1.0, 0.95]]";

fn phantom_input(n: u64, dir: [f64; 3], projection: &str) -> VolumeInput {
    phantom_with(n, 0.7, PHANTOM_TF, dir, projection)
}

fn phantom_with(n: u64, blur: f64, tf: &str, dir: [f64; 3], projection: &str) -> VolumeInput {
    let sc = scene(
        "head-phantom.nrrd",
        "s",
        [0.0; 3],
        n as f64,
        dir,
        [0.0, 0.0, 1.0],
        projection,
        96,
        tf,
    );
    VolumeInput::new(sc, Arc::new(head_phantom(n, blur))).unwrap()
}

fn load(path: &Path) -> VolumeInput {
    let scene = Scene::load(path).unwrap();
    let vol = pvrsim::data::io::read_volume(&scene.data.path, &scene.data.field).unwrap();
    VolumeInput::new(scene, Arc::new(vol)).unwrap()
}

/// Renders with shear-warp and the reference; asserts the bounds.
fn against_reference(name: &str, inp: &VolumeInput, max_bound: f64, rmse_bound: f64) {
    let (want, _) = grid_reference::render(inp, &Default::default());
    let (got, st) = shearwarp::render(inp, &ShearWarpOptions::default()).unwrap();
    let e = got.error_against(&want);
    println!(
        "{name}: shearwarp vs f64 reference {e}; axis {:?}, {} slices, {} samples",
        st.slicing_axis, st.slices, st.samples_taken
    );
    assert!(
        want.pixels.iter().filter(|p| p[3] > 0.5).count() > 200,
        "{name}: the scene must show something"
    );
    assert!(e.rmse <= rmse_bound, "{name}: {e}");
    assert!(e.max_abs <= max_bound, "{name}: {e}");
}

/// The bundled mni-crop grid (32^3 of mni152_t1) under an oblique
/// orthographic view with the mni152-view transfer function, `size`^2
/// pixels over 1.8 x its extent.
fn mni_crop(size: u32) -> VolumeInput {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/volume/mni-crop.nhdr");
    let vol = pvrsim::data::io::read_volume(&p, "intensity").unwrap();
    let (lo, hi) = vol.bounds();
    let c = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
    let ext = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    let sc = scene(
        &p.display().to_string(),
        "intensity",
        c,
        ext,
        [-2.0, 1.2, 0.9],
        [0.0, 0.0, 1.0],
        &format!("projection = \"orthographic\"\nheight = {}", 1.8 * ext),
        size,
        MNI_TF,
    );
    VolumeInput::new(sc, Arc::new(vol)).unwrap()
}

const MNI_TF: &str =
    "[[0.0, 0, 0, 0, 0], [0.16, 0.1, 0.1, 0.2, 0], [0.35, 0.45, 0.6, 0.95, 0.015], \
     [0.55, 0.85, 0.55, 0.45, 0.04], [0.68, 0.95, 0.72, 0.58, 0.08], \
     [0.8, 1.0, 0.97, 0.9, 0.5], [1.0, 1, 1, 1, 0.8]]";

/// Soft edges (the shared brain scenes' kind): the phantom blurred over
/// 2.5 voxels under the mni152-view TF, 1.25 voxels per pixel, oblique.
/// Measured: max-abs 13.76/255, RMSE 1.051/255 (VolPack on the shared
/// brain scenes: RMSE 1.8-2.0); bounds with a margin of ~25 %.
#[test]
fn error_against_the_f64_reference_soft_edges() {
    let inp = phantom_with(
        64,
        2.5,
        MNI_TF,
        [0.62, -0.70, 0.35],
        "projection = \"orthographic\"\nheight = 80",
    );
    against_reference("soft phantom", &inp, 17.0, 1.3);
}

/// Hard opaque silhouettes and volumes cut through tissue: the bilinear
/// warp of the composited intermediate image (one pixel per voxel) blurs
/// each silhouette over about one voxel, which a ray caster does not: the
/// error is several times larger. Measured (regression bounds ~25 % above):
/// lobster-view max-abs 75.09, RMSE 4.763; the 0.7-voxel phantom with its
/// near-opaque brain at 0.83 voxels per pixel max-abs 116.27, RMSE 6.696;
/// mni-crop (a 32^3 crop: its faces cut through tissue) at 1.1 voxels per
/// pixel max-abs 81.89, RMSE 7.635.
#[test]
fn error_against_the_f64_reference_hard_edges() {
    let lobster = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/scenes/lobster-view.toml");
    against_reference("lobster-view", &load(&lobster), 94.0, 6.0);
    let ph = phantom_input(
        64,
        [0.62, -0.70, 0.35],
        "projection = \"orthographic\"\nheight = 80",
    );
    against_reference("phantom", &ph, 145.0, 8.4);
    against_reference("mni-crop", &mni_crop(52), 102.0, 9.5);
}

#[test]
fn principal_axis_for_all_six_signs() {
    for c in 0..3 {
        for sign in [1.0, -1.0] {
            // The ray direction is target - eye = -dir.
            let mut d = [0.3, -0.25, 0.2];
            d[c] = -sign;
            let inp = phantom_input(8, d, "projection = \"orthographic\"\nheight = 12");
            let view = inp.scene.camera.view(8, 8);
            let f = Factor::new(&view, &inp.volume);
            assert_eq!(f.principal, c, "dir {d:?}");
            assert_eq!(f.front_is_zero, sign > 0.0, "dir {d:?}");
            assert_eq!(f.axes[2], c);
            assert!(f.shear.iter().all(|s| s.abs() <= 1.0), "{f:?}");
        }
    }
}

#[test]
fn perspective_is_refused_with_a_clear_error() {
    let inp = phantom_input(
        16,
        [1.0, -1.0, 0.5],
        "projection = \"perspective\"\nfov_y_deg = 40",
    );
    let m = match shearwarp::render(&inp, &ShearWarpOptions::default()) {
        Ok(_) => panic!("perspective must be refused"),
        Err(e) => e.to_string(),
    };
    assert!(
        m.contains("perspective") && m.contains("orthographic"),
        "{m}"
    );
}

#[test]
fn bad_ert_is_refused() {
    let inp = phantom_input(
        8,
        [1.0, -1.0, 0.5],
        "projection = \"orthographic\"\nheight = 12",
    );
    for ert in [0.0, -1.0, 1.5, f32::NAN] {
        let o = ShearWarpOptions {
            ert,
            ..Default::default()
        };
        assert!(shearwarp::render(&inp, &o).is_err(), "ert {ert}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Skipping the transparent runs changes no pixel: random u8 volumes
    /// (mostly zero with blobs), random transfer functions with transparent
    /// stretches, random view directions.
    #[test]
    fn rle_skipping_is_exact(
        dims in prop::array::uniform3(2u64..12),
        seed in any::<u64>(),
        dir in prop::array::uniform3(-1.0f64..1.0),
        zero_until in 0.0f64..0.6,
        op in 0.01f64..1.0,
        ert in prop::sample::select(vec![0.9f32, 0.99, 1.0]),
    ) {
        prop_assume!(dir.iter().map(|x| x * x).sum::<f64>() > 0.05);
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let mut x = seed | 1;
        let vox: Vec<u8> = (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                if x % 3 == 0 { (x >> 20) as u8 } else { 0 }
            })
            .collect();
        let vol = Volume::new(Path::new("rand"), dims, [1.0, 1.3, 0.8], [0.0; 3], "s", Voxels::U8(vox)).unwrap();
        let (lo, hi) = vol.bounds();
        let c: Vec<f64> = (0..3).map(|a| 0.5 * (lo[a] + hi[a])).collect();
        let ext = (0..3).map(|a| hi[a] - lo[a]).fold(1.0, f64::max);
        let up = if dir[2].abs() > 0.9 * dir.iter().map(|x| x.abs()).fold(0.0, f64::max) {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 0.0, 1.0]
        };
        let tf = format!(
            "[[0.0, 1, 0, 0, 0], [{z}, 0.5, 0.5, 0, 0], [{m}, 0, 1, 0, {op}], [1.0, 0.2, 0.3, 1, {op2}]]",
            z = zero_until,
            m = zero_until + 0.2,
            op2 = op * 0.5,
        );
        let sc = scene("rand.nrrd", "s", [c[0], c[1], c[2]], ext, dir, up,
            &format!("projection = \"orthographic\"\nheight = {}", 1.8 * ext), 24, &tf);
        prop_assume!(sc.camera.check().is_ok());
        let inp = VolumeInput::new(sc, Arc::new(vol)).unwrap();
        let on = ShearWarpOptions { ert, empty_skip: true };
        let off = ShearWarpOptions { empty_skip: false, ..on };
        let (a, sa) = shearwarp::render(&inp, &on).unwrap();
        let (b, sb) = shearwarp::render(&inp, &off).unwrap();
        prop_assert!(a.pixels == b.pixels, "skipping changed the image: {}", a.error_against(&b));
        prop_assert!(sa.samples_taken <= sb.samples_taken);
        prop_assert_eq!(sb.samples_skipped_empty, 0);
    }
}

/// A transfer-function edit keeps the run-length encodings when every cell
/// they skip stays transparent (colours, opacities kept non-zero, values
/// made transparent), and falls back to runs over min-max blocks when it
/// makes skipped values visible (then `refine` re-encodes per cell); a
/// frame on encodings that would skip visible values is refused. Every
/// image equals a fresh render's, bit for bit.
#[test]
fn transfer_function_edits_reencode_only_what_they_reveal() {
    let base = phantom_input(
        32,
        [0.3, -0.5, 0.8],
        "projection = \"orthographic\"\nheight = 40",
    );
    let opts = ShearWarpOptions::default();
    let mut prep = shearwarp::prepare(&base);
    let edit = |f: &dyn Fn(&mut pvrsim::scene::transfer::ControlPoint)| {
        let mut e = base.clone();
        e.scene.transfer.points.iter_mut().for_each(f);
        e
    };
    // The opacity of the control point at `s` set to `o`.
    let opacity_at = |s: f64, o: f64| {
        let mut e = base.clone();
        let p = e
            .scene
            .transfer
            .points
            .iter_mut()
            .find(|p| (p.s - s).abs() < 1e-9);
        p.expect("a control point at s").opacity = o;
        e
    };
    let fresh = |inp: &VolumeInput| shearwarp::render(inp, &opts).unwrap().0;
    // (name, edited input, re-encodes; the kept or block runs then skip
    // fewer cells than a per-cell encoding under the edit would)
    let cases = [
        (
            "recoloured",
            edit(&|p| p.rgb = [p.rgb[2], p.rgb[0], p.rgb[1]]),
            false,
            false,
        ),
        ("opacity halved", edit(&|p| p.opacity *= 0.5), false, false),
        ("skin made transparent", opacity_at(0.27, 0.0), false, true),
        ("fat revealed", opacity_at(0.6, 0.3), true, true),
    ];
    for (name, inp, reencodes, coarser) in cases {
        let refused = shearwarp::render_prepared(&inp, &prep, &opts).is_err();
        assert_eq!(refused, reencodes, "{name}: a frame on the old encodings");
        assert_eq!(prep.reclassify(&inp), reencodes, "{name}: re-encoded");
        let (got, st) = shearwarp::render_prepared(&inp, &prep, &opts).unwrap();
        assert!(
            got.pixels == fresh(&inp).pixels,
            "{name}: {}",
            got.error_against(&fresh(&inp))
        );
        let mut refined = prep.clone();
        refined.refine(&inp);
        let (fine, sf) = shearwarp::render_prepared(&inp, &refined, &opts).unwrap();
        assert!(
            fine.pixels == got.pixels,
            "{name}, refined: {}",
            fine.error_against(&got)
        );
        // Block runs skip less than per-cell runs, never more.
        assert!(
            sf.samples_taken <= st.samples_taken,
            "{name}: {sf:?} vs {st:?}"
        );
        assert_eq!(
            sf.samples_taken < st.samples_taken,
            coarser,
            "{name}: coarser runs"
        );
        // Back to the scene's own TF for the next case.
        prep = shearwarp::prepare(&base);
    }
}
