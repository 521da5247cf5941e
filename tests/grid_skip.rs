//! Empty-space skipping and the close-up perspective (issue 22):
//!
//! - skipping is exact: the image with the min–max blocks' skipping and
//!   leaping equals the one without it, within 1/255 (in fact bit for bit:
//!   the same samples at the same positions, and a skipped sample's block
//!   has zero opacity over its whole range, so it would add exactly zero)
//!   on the generated head phantom and the bundled mni-crop grid, always,
//!   and on the shared grid scenes when present;
//! - a perspective view from close by through a faint outer shell (skin)
//!   onto opaque inner surfaces (the generated head phantom) renders within
//!   max-abs 8/255 and RMSE 1/255 of the f64 grid reference;
//! - sort-last: colin27-brain-view on 4 nodes, d = 2, default codec, ERT
//!   off on both, within 1/255 of single-node slice3d (when the shared data
//!   are present; the phantom always).

use std::path::Path;
use std::sync::Arc;

use clap::Parser;
use pvrsim::cli::{Cli, Command as Cmd};
use pvrsim::render::shearwarp::{self, ShearWarpOptions};
use pvrsim::render::slice3d::{self, Slice3dOptions};
use pvrsim::render::{grid_reference, VolumeInput};
use pvrsim::scene::Scene;

mod phantom;
use phantom::head_phantom;

mod support;
use support::shared;

/// The phantom seen in perspective from close by: the eye 1.15 n from the
/// centre (0.68 n outside the skin), 60° field of view; faint skin
/// (opacity 0.04 per mm), the fat transparent, the brain opaque.
pub fn phantom_scene(n: u64, size: u32) -> VolumeInput {
    let d = 1.15 * n as f64;
    let sc = Scene::parse(
        &format!(
            r#"
[data]
path = "head-phantom.nrrd"
field = "s"
range = [0, 255]
[camera]
eye = [{ex}, {ey}, {ez}]
target = [0, 0, 0]
up = [0, 0, 1]
projection = "perspective"
fov_y_deg = 60
[image]
width = {size}
height = {size}
background = [0, 0, 0]
[transfer]
unit_distance = 1
points = [[0.0, 0, 0, 0, 0], [0.16, 0.9, 0.7, 0.6, 0], [0.27, 0.95, 0.75, 0.65, 0.04],
          [0.38, 0.9, 0.7, 0.6, 0], [0.6, 0.8, 0.8, 0.9, 0], [0.8, 1.0, 0.95, 0.85, 0.9],
          [1.0, 1.0, 1.0, 1.0, 0.95]]
"#,
            ex = 0.62 * d,
            ey = -0.70 * d,
            ez = 0.35 * d,
        ),
        Path::new("head-phantom.toml"),
    )
    .unwrap();
    VolumeInput::new(sc, Arc::new(head_phantom(n, 0.7))).unwrap()
}

fn load(path: &Path) -> VolumeInput {
    let scene = Scene::load(path).unwrap();
    let vol = pvrsim::data::io::read_volume(&scene.data.path, &scene.data.field).unwrap();
    VolumeInput::new(scene, Arc::new(vol)).unwrap()
}

/// The bundled mni-crop grid under an oblique orthographic view with the
/// mni152-view transfer function.
fn mni_crop() -> VolumeInput {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/volume/mni-crop.nhdr");
    let vol = pvrsim::data::io::read_volume(&p, "intensity").unwrap();
    let (lo, hi) = vol.bounds();
    let c: Vec<f64> = (0..3).map(|a| 0.5 * (lo[a] + hi[a])).collect();
    let ext = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    let sc = Scene::parse(
        &format!(
            r#"
[data]
path = "{path}"
field = "intensity"
[camera]
eye = [{e0}, {e1}, {e2}]
target = [{c0}, {c1}, {c2}]
up = [0, 0, 1]
projection = "orthographic"
height = {h}
[image]
width = 96
height = 96
background = [0, 0, 0]
[transfer]
unit_distance = 1
points = [[0.0, 0, 0, 0, 0], [0.16, 0.1, 0.1, 0.2, 0], [0.35, 0.45, 0.6, 0.95, 0.015],
          [0.55, 0.85, 0.55, 0.45, 0.04], [0.68, 0.95, 0.72, 0.58, 0.08],
          [0.8, 1.0, 0.97, 0.9, 0.5], [1.0, 1, 1, 1, 0.8]]
"#,
            path = p.display(),
            e0 = c[0] - 2.0 * ext,
            e1 = c[1] + 1.2 * ext,
            e2 = c[2] + 0.9 * ext,
            c0 = c[0],
            c1 = c[1],
            c2 = c[2],
            h = 1.8 * ext,
        ),
        &p,
    )
    .unwrap();
    VolumeInput::new(sc, Arc::new(vol)).unwrap()
}

fn skip_on_off(name: &str, inp: &VolumeInput) {
    let on = Slice3dOptions::default();
    let off = Slice3dOptions {
        empty_skip: false,
        ..on
    };
    let (a, sa) = slice3d::render(inp, &on).unwrap();
    let (b, sb) = slice3d::render(inp, &off).unwrap();
    let e = a.error_against(&b);
    println!(
        "{name}: skipping on vs off {e}; samples taken {} vs {}, skipped empty {} ({} of {} blocks empty)",
        sa.samples_taken, sb.samples_taken, sa.samples_skipped_empty, sa.blocks_empty, sa.blocks
    );
    assert!(e.max_abs <= 1.0, "{name}: {e}");
    assert_eq!(a, b, "{name}: skipping is exact, the images are equal");
    assert!(sa.samples_taken <= sb.samples_taken);
    assert_eq!(sb.samples_skipped_empty, 0);
    // Shear-warp, the default for orthographic views: its run-length
    // encoding skips exactly too.
    let on = ShearWarpOptions::default();
    if shearwarp::check(inp, &on).is_ok() {
        let off = ShearWarpOptions {
            empty_skip: false,
            ..on
        };
        let (a, sa) = shearwarp::render(inp, &on).unwrap();
        let (b, sb) = shearwarp::render(inp, &off).unwrap();
        println!(
            "{name}: shearwarp skipping on vs off {}; samples taken {} vs {}",
            a.error_against(&b),
            sa.samples_taken,
            sb.samples_taken
        );
        assert_eq!(
            a, b,
            "{name}: shear-warp skipping is exact, the images are equal"
        );
        assert!(
            sa.samples_taken < sb.samples_taken,
            "{name}: shear-warp skips"
        );
    }
}

#[test]
fn skipping_changes_no_image() {
    let ph = phantom_scene(64, 96);
    skip_on_off("head phantom 64^3", &ph);
    skip_on_off("mni-crop", &mni_crop());
    for s in [
        "mni152-view.toml",
        "colin27-brain-view.toml",
        "frog-view.toml",
    ] {
        if let Some(p) = shared(s) {
            skip_on_off(s, &load(&p));
        }
    }
    let lobster = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/scenes/lobster-view.toml");
    if shared("lobster.fld").is_some() {
        skip_on_off("lobster-view.toml", &load(&lobster));
    }
}

#[test]
fn close_perspective_through_a_faint_shell_within_8_and_rmse_1() {
    let inp = phantom_scene(96, 128);
    let (want, rs) = grid_reference::render(&inp, &Default::default());
    assert_eq!(rs.quadrature_depth_limited, 0);
    let (got, st) = slice3d::render(&inp, &Slice3dOptions::default()).unwrap();
    assert!(
        want.pixels.iter().filter(|p| p[3] > 0.9).count() > 2000,
        "opaque inner surfaces must be seen"
    );
    let e = got.error_against(&want);
    println!(
        "head phantom 96^3, perspective close-up: slice3d ({} slices) vs reference {e}",
        st.slices
    );
    // Where the large errors came from (docs/experiments/grids.md): the
    // default slice count followed the central view direction only, so the
    // off-axis rays of a wide perspective sampled the thin skin more
    // coarsely (max 9.4/255 at 266 slices; 2x slices 2.7/255); with the
    // count taken from the ray crossing the most cell faces per unit depth
    // (315 slices) it is 5.2/255. ERT 0.99 adds its bound (2.6/255 here) to
    // the RMSE: with ERT off the RMSE is 0.20/255.
    let e_off = slice3d::render(
        &inp,
        &Slice3dOptions {
            ert: 1.0,
            ..Default::default()
        },
    )
    .unwrap()
    .0
    .error_against(&want);
    println!("the same with ERT off: {e_off}");
    assert!(e_off.max_abs <= 8.0 && e_off.rmse <= 0.5, "{e_off}");
    assert!(e.max_abs <= 8.0 && e.rmse <= 1.0, "{e}");
}

fn cluster_vs_single(name: &str, scene: &Path, inp: &VolumeInput) {
    let v = [
        "pvrsim",
        "cluster",
        scene.to_str().unwrap(),
        "--nodes",
        "4",
        "--subvolumes",
        "2",
        "--ert",
        "1",
    ];
    let Cmd::Cluster(a) = Cli::try_parse_from(v).unwrap().command else {
        unreachable!()
    };
    let cfg = pvrsim::cli::cluster_grid::config(&pvrsim::job::Valid::new(&*a).unwrap()).unwrap();
    let out = pvrsim::cluster::grid::run(inp, &cfg).unwrap();
    let one = slice3d::render(
        inp,
        &Slice3dOptions {
            ert: 1.0,
            ..Default::default()
        },
    )
    .unwrap()
    .0;
    let e = out.image.error_against(&one);
    println!(
        "{name}: sort-last 4 nodes d=2 {} vs single-node slice3d (ERT off): {e}",
        cfg.codec
    );
    assert!(e.max_abs <= 1.0, "{name}: {e}");
}

#[test]
fn sort_last_within_1_of_single_node() {
    if let Some(p) = shared("colin27-brain-view.toml") {
        cluster_vs_single("colin27-brain-view", &p, &load(&p));
    }
    // The scene file is only parsed for its options here; the volume is the input.
    let inp = phantom_scene(64, 96);
    cluster_vs_single("head phantom 64^3", Path::new("head-phantom.toml"), &inp);
}
