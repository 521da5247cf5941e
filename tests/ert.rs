//! Early ray termination: the error bound, thread independence and the oracle.
//!
//! The bound (scene.md): per pixel and channel, |ERT image - full image| <=
//! (1 - threshold) * max emitted radiance (the renderer reports it as
//! `ert_error_bound`; on a coloured background the background's largest
//! channel counts too).

use std::path::Path;
use std::sync::Arc;

use proptest::prelude::*;
use pvrsim::data::lattice::kuhn_tets;
use pvrsim::data::{Field, TetMesh};
use pvrsim::image::Image;
use pvrsim::render::cell::ert::EntrySize;
use pvrsim::render::cell::{
    self, CellOptions, CellOrder, CellStats, ErtOptions, ErtSpan, ErtStructure,
};
use pvrsim::render::{reference, RenderInput};
use pvrsim::scene::Scene;

/// Slack for f32 rounding: merges happen in a different order with ERT.
const EPS: f32 = 2e-4;

/// A jittered `n^3` grid of cubes, each cut into the 6 Kuhn tetrahedra
/// (conforming), with a random scalar per vertex.
fn random_mesh(n: usize, seed: u64) -> TetMesh {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut rnd = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) as f64) / (1u64 << 31) as f64
    };
    let m = n + 1;
    let mut points = Vec::new();
    let mut values = Vec::new();
    for k in 0..m {
        for j in 0..m {
            for i in 0..m {
                let jit = |v: usize, r: f64| {
                    if v == 0 || v == n {
                        v as f64
                    } else {
                        v as f64 + 0.3 * (r - 0.5)
                    }
                };
                points.push([jit(i, rnd()), jit(j, rnd()), jit(k, rnd())]);
                values.push(rnd());
            }
        }
    }
    let tets = kuhn_tets([n; 3], |_, _, _| true);
    TetMesh {
        points,
        tets,
        fields: vec![Field {
            name: "f".into(),
            components: 1,
            values,
        }],
    }
}

fn scene(
    n: usize,
    dir: [f64; 3],
    perspective: bool,
    tf: &[[f64; 5]],
    unit: f64,
    size: u32,
) -> Scene {
    let c = n as f64 / 2.0;
    let eye = [
        c + 3.0 * n as f64 * dir[0],
        c + 3.0 * n as f64 * dir[1],
        c + 3.0 * n as f64 * dir[2],
    ];
    let up = if dir[2].abs() > 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let proj = if perspective {
        "projection = \"perspective\"\nfov_y_deg = 30.0"
    } else {
        "projection = \"orthographic\""
    };
    let points: Vec<String> = tf
        .iter()
        .map(|p| format!("[{}, {}, {}, {}, {}]", p[0], p[1], p[2], p[3], p[4]))
        .collect();
    let text = format!(
        "[data]\npath = \"x.vtk\"\nfield = \"f\"\nrange = [0.0, 1.0]\n[camera]\neye = [{}, {}, {}]\ntarget = [{c}, {c}, {c}]\nup = [{}, {}, {}]\n{proj}\nheight = {}\n[image]\nwidth = {size}\nheight = {size}\nbackground = [0.0, 0.0, 0.0]\n[transfer]\nunit_distance = {unit}\npoints = [{}]\n",
        eye[0],
        eye[1],
        eye[2],
        up[0],
        up[1],
        up[2],
        1.9 * n as f64,
        points.join(", ")
    );
    Scene::parse(&text, Path::new("/tmp/x.toml")).expect("scene")
}

fn render(input: &RenderInput, opts: &CellOptions, threads: usize) -> (Image, CellStats) {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| cell::render(input, opts))
}

fn ert(
    threshold: f32,
    structure: ErtStructure,
    span: ErtSpan,
    entry: Option<EntrySize>,
    c: u32,
) -> ErtOptions {
    ErtOptions {
        mode: pvrsim::render::cell::ert::ErtMode::of_threshold(threshold),
        entry,
        update_c: c,
        span,
        structure,
        backoff: true,
    }
}

fn off() -> CellOptions {
    CellOptions {
        ert: ErtOptions::OFF,
        ..Default::default()
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// |ERT - full| <= bound on random meshes, transfer functions, views and ERT settings.
    #[test]
    fn error_bound_holds_on_random_scenes(
        seed in 0u64..1_000_000,
        n in 2usize..6,
        dir in (-1.0f64..1.0, -1.0f64..1.0, 0.2f64..1.0),
        perspective in any::<bool>(),
        tf in prop::collection::vec((0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0, 0.0f64..0.95), 2..5),
        unit in 0.1f64..2.0,
        threshold in 0.3f32..0.995,
        pyramid in any::<bool>(),
        multi in any::<bool>(),
        entry in 1u32..12,
        c in 1u32..400,
        stored in any::<bool>(),
        partial in any::<bool>(),
        tile in 4u32..40,
    ) {
        let len = (dir.0 * dir.0 + dir.1 * dir.1 + dir.2 * dir.2).sqrt();
        let dir = [dir.0 / len, dir.1 / len, dir.2 / len];
        let k = tf.len();
        let pts: Vec<[f64; 5]> = tf.iter().enumerate().map(|(i, p)| [i as f64 / (k - 1) as f64, p.0, p.1, p.2, p.3]).collect();
        let input = RenderInput::new(scene(n, dir, perspective, &pts, unit, 48), Arc::new(random_mesh(n, seed))).unwrap();
        let base = CellOptions {
            cell_order: if stored { CellOrder::Stored } else { CellOrder::FrontToBack },
            partial_composition: partial,
            tile_size: tile,
            ..Default::default()
        };
        let (full, _) = render(&input, &CellOptions { ert: ErtOptions::OFF, ..base }, 1);
        let structure = if pyramid { ErtStructure::Pyramid } else { ErtStructure::Flat };
        let span = if multi { ErtSpan::Multi } else { ErtSpan::Single };
        let opts = CellOptions { ert: ert(threshold, structure, span, Some(EntrySize::Pixels(entry)), c), ..base };
        let (img, stats) = render(&input, &opts, 1);
        let bound = stats.ert_error_bound as f32;
        let want = (1.0 - threshold as f64) * input.scene.transfer.max_radiance();
        prop_assert!((stats.ert_error_bound - want).abs() < 1e-6, "reported bound {} != {}", stats.ert_error_bound, want);
        let d = (img.error_against(&full).max_abs / 255.0) as f32;
        prop_assert!(d <= bound + EPS, "max |ERT - full| = {d} > bound {bound} ({} cells skipped)", stats.cells_skipped_ert);
    }
}

/// A deterministic dense case where ERT must skip cells, so the bound is
/// tested on a non-trivial image (guards against the property test passing
/// only because nothing was skipped).
#[test]
fn dense_scene_skips_cells_within_the_bound() {
    let pts = [[0.0, 1.0, 1.0, 1.0, 0.9], [1.0, 0.2, 0.5, 1.0, 0.9]];
    let input = RenderInput::new(
        scene(8, [0.3, 0.2, 0.93], false, &pts, 0.3, 64),
        Arc::new(random_mesh(8, 7)),
    )
    .unwrap();
    let (full, _) = render(&input, &off(), 1);
    for structure in [ErtStructure::Flat, ErtStructure::Pyramid] {
        for threshold in [0.5, 0.9, 0.99] {
            let opts = CellOptions {
                ert: ert(threshold, structure, ErtSpan::Multi, None, 100),
                ..Default::default()
            };
            let (img, stats) = render(&input, &opts, 1);
            assert!(
                stats.cells_skipped_ert > 0,
                "{structure} at {threshold} skipped nothing"
            );
            let d = (img.error_against(&full).max_abs / 255.0) as f32;
            assert!(
                d <= stats.ert_error_bound as f32 + EPS,
                "{structure} at {threshold}: {d} > {}",
                stats.ert_error_bound
            );
            assert!(
                d > 0.0 || threshold > 0.95,
                "ERT changed nothing at {threshold}: suspicious"
            );
        }
    }
}

#[test]
fn ert_off_runs_nothing() {
    let pts = [[0.0, 1.0, 1.0, 1.0, 0.9], [1.0, 0.2, 0.5, 1.0, 0.9]];
    let input = RenderInput::new(
        scene(4, [0.3, 0.2, 0.93], false, &pts, 0.3, 32),
        Arc::new(random_mesh(4, 3)),
    )
    .unwrap();
    let (_, s) = render(&input, &off(), 1);
    assert_eq!(
        (
            s.ert_updates,
            s.ert_tests,
            s.cells_skipped_ert,
            s.ert_error_bound
        ),
        (0, 0, 0, 0.0)
    );
    assert_eq!(s.time_scan_s, s.time_scan_phase_s);
}

fn small(view: &str) -> RenderInput {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(format!("aorta-small-view-{view}.toml"));
    RenderInput::load(&path).unwrap().0
}

/// The image does not depend on the thread count with ERT on.
#[test]
fn ert_image_is_independent_of_threads() {
    let input = small("b");
    for structure in [ErtStructure::Flat, ErtStructure::Pyramid] {
        let opts = CellOptions {
            ert: ert(0.9, structure, ErtSpan::Multi, None, 100),
            ..Default::default()
        };
        let (a, sa) = render(&input, &opts, 1);
        let (b, sb) = render(&input, &opts, 3);
        assert_eq!(a.pixels, b.pixels, "{structure}");
        assert_eq!(sa.cells_skipped_ert, sb.cells_skipped_ert);
    }
}

/// The back-off (no tests while no pixel of a tile has terminated in front
/// of a cell) changes no skip decision: the image and the skipped cells are
/// the same with it and without it, for both structures, at a threshold
/// where ERT skips many cells and at the default.
#[test]
fn ert_backoff_changes_no_image() {
    for view in ["a", "b"] {
        let input = small(view);
        for structure in [ErtStructure::Flat, ErtStructure::Pyramid] {
            for threshold in [0.5, 0.99] {
                let on = ert(threshold, structure, ErtSpan::Multi, None, 100);
                let opts = |backoff| CellOptions {
                    ert: ErtOptions { backoff, ..on },
                    ..Default::default()
                };
                let (a, sa) = render(&input, &opts(true), 1);
                let (b, sb) = render(&input, &opts(false), 1);
                let what = format!("view {view}, {structure}, {threshold}");
                assert_eq!(a.pixels, b.pixels, "{what}");
                assert_eq!(sa.cells_skipped_ert, sb.cells_skipped_ert, "{what}");
                assert_eq!(
                    sa.cell_tile_pairs_skipped_ert, sb.cell_tile_pairs_skipped_ert,
                    "{what}"
                );
                assert!(sa.ert_tests <= sb.ert_tests, "{what}");
                if threshold == 0.5 {
                    assert!(sb.cells_skipped_ert > 0, "{what}: nothing skipped");
                }
            }
        }
    }
}

/// Against the reference on both aorta-small views: ERT stays within the
/// bound of the full image, and no farther from the reference than the full
/// image plus the bound; every mode's skipped cells are a subset of the oracle's.
#[test]
fn aorta_small_against_reference_and_oracle() {
    for view in ["a", "b"] {
        let input = small(view);
        let adjacency = input.mesh.adjacency();
        let (reference, _) = reference::render(&input, &adjacency, &Default::default());
        let (full, _) = render(&input, &off(), 2);
        let modes = [
            ert(
                0.9,
                ErtStructure::Flat,
                ErtSpan::Single,
                Some(EntrySize::Pixels(5)),
                100,
            ),
            ert(
                0.9,
                ErtStructure::Flat,
                ErtSpan::Multi,
                Some(EntrySize::Pixels(5)),
                100,
            ),
            ert(0.9, ErtStructure::Pyramid, ErtSpan::Multi, None, 100),
            ert(0.99, ErtStructure::Pyramid, ErtSpan::Multi, None, 100),
        ];
        let mut skipped = Vec::new();
        for m in modes {
            let opts = CellOptions {
                ert: m,
                oracle: true,
                ..Default::default()
            };
            let (img, s) = render(&input, &opts, 2);
            let bound = s.ert_error_bound as f32;
            assert!(
                (img.error_against(&full).max_abs / 255.0) as f32 <= bound + EPS,
                "view {view} {m:?}"
            );
            for ((p, q), r) in img.pixels.iter().zip(&full.pixels).zip(&reference.pixels) {
                for c in 0..3 {
                    assert!(
                        (p[c] - r[c]).abs() <= (q[c] - r[c]).abs() + bound + EPS,
                        "view {view} {m:?}"
                    );
                }
            }
            let oracle = s.oracle_cells_skippable.unwrap();
            assert!(
                s.cells_skipped_ert <= oracle,
                "view {view} {m:?}: {} > oracle {oracle}",
                s.cells_skipped_ert
            );
            if m.threshold() < 0.95 {
                assert!(oracle > 0 && s.cells_skipped_ert > 0, "view {view} {m:?}");
            }
            skipped.push(s.cells_skipped_ert);
        }
        // Multi-entry tests include the single-entry ones; the pyramid beats the flat table here.
        assert!(
            skipped[1] >= skipped[0] && skipped[2] >= skipped[1],
            "view {view}: {skipped:?}"
        );
    }
}
