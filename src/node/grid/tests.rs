//! Bricks against the single-node renderer (no seams), visibility order
//! along rays (property test), placement.

use std::sync::Arc;

use proptest::prelude::*;

use super::bricks::{extract, place, split, visibility_ranks, BrickPlacement};
use super::render::{render_brick, slice3d_renderer, whole_planes, LayerSpec};

use crate::compositor::layer::{composite, Depth, Layer};
use crate::render::grid_reference::tests::{scene, volume};
use crate::render::slice3d::{self, Slice3dOptions};
use crate::render::VolumeInput;
use crate::scene::View;

/// A dense Gaussian whose peak sits exactly on the brick faces of `d = 2`
/// (sample 16 of 33, 14 of 29, 12 of 25 are the cut points).
pub(crate) fn seam_input(camera: &str, size: u32) -> VolumeInput {
    let v = volume([33, 29, 25], [1.0, 1.0, 1.0], [-16.0, -14.0, -12.0], |p| {
        let r2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
        (255.0 * (-r2 / 30.0).exp()) as f32
    });
    let sc = scene(
        camera,
        "unit_distance = 1\npoints = [[0, 0, 0, 0, 0], [0.3, 0.2, 0.5, 1, 0.05], [1, 1, 0.9, 0.6, 0.5]]",
        size,
        Some([0.0, 255.0]),
    );
    VolumeInput::new(sc, Arc::new(v)).unwrap()
}

pub(crate) const OBLIQUE: &str = "eye = [40, -25, 30]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\nprojection = \"orthographic\"\nheight = 44";
pub(crate) const AXIS: &str = "eye = [0, 0, 60]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nprojection = \"orthographic\"\nheight = 36";
pub(crate) const PERSP: &str = "eye = [40, -25, 30]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\nprojection = \"perspective\"\nfov_y_deg = 40";

/// Renders `inp` as `d^3` bricks and composites their layers over the
/// background: layers at `depth`, or the f32 subimages (`None`).
pub(crate) fn bricked(
    inp: &VolumeInput,
    d: u32,
    opts: &Slice3dOptions,
    layer_depth: Option<Depth>,
) -> crate::image::Image {
    let depth = layer_depth.unwrap_or(Depth::U16);
    let s = &inp.scene;
    let view = s.camera.view(s.image.width, s.image.height);
    let bricks = split(inp.volume.dims, d).unwrap();
    let ranks = visibility_ranks(&view, &inp.volume, d, &bricks);
    let planes = whole_planes(inp, opts).unwrap();
    let r = slice3d_renderer();
    let layers: Vec<super::render::BrickOutput> = bricks
        .iter()
        .map(|b| {
            let v = Arc::new(extract(&inp.volume, b));
            render_brick(
                inp,
                planes,
                b,
                v,
                LayerSpec {
                    rank: ranks[b.id as usize],
                    depth,
                },
                opts,
                &*r,
            )
            .unwrap()
        })
        .collect();
    let screen = crate::compositor::region::screen(s.image.width, s.image.height);
    let px = if layer_depth.is_none() {
        // Front to back over the f32 subimages, in rank order.
        let mut order: Vec<&super::render::BrickOutput> = layers.iter().collect();
        order.sort_by_key(|o| o.layer.ranks[0]);
        let w = s.image.width as usize;
        let mut out = vec![[0f32; 4]; w * s.image.height as usize];
        for o in order {
            let rc = o.layer.rect;
            for y in rc.y0..rc.y1 {
                for x in rc.x0..rc.x1 {
                    let src = o.exact[((y - rc.y0) * rc.width() + (x - rc.x0)) as usize];
                    let d = &mut out[y as usize * w + x as usize];
                    let t = 1.0 - d[3];
                    for c in 0..4 {
                        d[c] += t * src[c];
                    }
                }
            }
        }
        out
    } else {
        let refs: Vec<&Layer> = layers.iter().map(|o| &o.layer).collect();
        composite(&screen, &refs).unwrap()
    };
    let bg = s.image.background.map(|x| x as f32);
    let mut img = crate::image::Image::new(s.image.width, s.image.height);
    for (o, p) in img.pixels.iter_mut().zip(px) {
        let t = 1.0 - p[3];
        *o = [p[0] + t * bg[0], p[1] + t * bg[1], p[2] + t * bg[2], p[3]];
    }
    img
}

#[test]
fn bricks_cutting_the_densest_feature_show_no_seam() {
    let opts = Slice3dOptions {
        ert: 1.0,
        ..Default::default()
    };
    for cam in [OBLIQUE, AXIS, PERSP] {
        let inp = seam_input(cam, 64);
        let (one, _) = slice3d::render(&inp, &opts).unwrap();
        assert!(
            one.pixels.iter().any(|p| p[3] > 0.5),
            "the feature must be dense"
        );
        for d in [1, 2, 3] {
            // Exact subimages: the same samples in the same order, so the
            // same image up to f32 regrouping of "over".
            let e = bricked(&inp, d, &opts, None).error_against(&one);
            assert!(e.max_abs <= 0.05, "{cam} d={d} f32 layers: {e}");
            // Fixed-point layers: a layer's colour and alpha each round by
            // at most 1/(2M), so "over" moves by at most
            // |dC_f| + |dA_f| C_b <= 1/M per layer (C_b <= 1, background
            // included); a ray crosses at most 3d - 2 bricks. In 1/255
            // units: 3d - 2 at 8 bits, (3d - 2) 255/65535 at 16 bits.
            for (depth, per_layer) in [(Depth::U8, 1.0), (Depth::U16, 255.0 / 65535.0)] {
                let e = bricked(&inp, d, &opts, Some(depth)).error_against(&one);
                let bound = (3 * d - 2) as f64 * per_layer + 0.05;
                assert!(
                    e.max_abs <= bound,
                    "{cam} d={d} {depth:?} layers: {e} (bound {bound})"
                );
                if depth == Depth::U16 {
                    assert!(e.max_abs <= 1.0, "{cam} d={d} RGBA16: {e}");
                }
                eprintln!(
                    "{} d={d} {depth:?} layers vs slice3d: {e}",
                    cam.lines().last().unwrap()
                );
            }
        }
    }
}

#[test]
fn a_brick_owns_each_sample_once() {
    // With the transfer function's opacity constant, every sample counts:
    // the bricks' samples add up to the whole's, whatever the view.
    let opts = Slice3dOptions {
        ert: 1.0,
        empty_skip: false,
        ..Default::default()
    };
    for cam in [OBLIQUE, AXIS, PERSP] {
        let inp = seam_input(cam, 40);
        let (_, whole) = slice3d::render(&inp, &opts).unwrap();
        let planes = whole_planes(&inp, &opts).unwrap();
        let view = inp.scene.camera.view(40, 40);
        let bricks = split(inp.volume.dims, 2).unwrap();
        let ranks = visibility_ranks(&view, &inp.volume, 2, &bricks);
        // slice3d and adaptive block sampling honour the brick clip alike:
        // no sample lost or doubled at a brick face (no seam).
        for kind in [
            super::render::RendererKind::Slice3d,
            super::render::RendererKind::Adaptive {
                blocks: 3,
                tolerance: 0.05,
            },
        ] {
            let r = kind.build();
            let sum: u64 = bricks
                .iter()
                .map(|b| {
                    let v = Arc::new(extract(&inp.volume, b));
                    render_brick(
                        &inp,
                        planes,
                        b,
                        v,
                        LayerSpec {
                            rank: ranks[b.id as usize],
                            depth: Depth::U16,
                        },
                        &opts,
                        &*r,
                    )
                    .unwrap()
                    .stats
                    .samples_taken
                })
                .sum();
            assert_eq!(sum, whole.samples_taken, "{cam} {kind:?}");
        }
    }
}

/// The brick holding grid point `g` (interior points only).
fn brick_of(g: [f64; 3], dims: [u64; 3], d: u32) -> Option<u32> {
    let mut idx = [0u32; 3];
    for a in 0..3 {
        let c = super::bricks::cuts(dims[a], d);
        if g[a] <= 0.0 || g[a] >= (dims[a] - 1) as f64 {
            return None;
        }
        idx[a] = (0..d as usize).find(|&i| g[a] < c[i + 1] as f64)? as u32;
    }
    Some(idx[0] + d * (idx[1] + d * idx[2]))
}

fn check_rays(view: &View, inp: &VolumeInput, d: u32) -> Result<(), TestCaseError> {
    let bricks = split(inp.volume.dims, d).unwrap();
    let ranks = visibility_ranks(view, &inp.volume, d, &bricks);
    for j in (0..view.height).step_by(3) {
        for i in (0..view.width).step_by(3) {
            let (o, dir) = view.ray(i, j);
            let mut last: Option<u32> = None;
            for s in 0..4000 {
                let t = 0.037 * s as f64;
                let p = [o[0] + t * dir[0], o[1] + t * dir[1], o[2] + t * dir[2]];
                if let Some(b) = brick_of(inp.volume.world_to_grid(p), inp.volume.dims, d) {
                    let r = ranks[b as usize];
                    if let Some(q) = last {
                        prop_assert!(r >= q, "pixel ({i},{j}): rank {r} after {q}");
                    }
                    last = Some(r);
                }
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn visibility_order_holds_along_every_ray(
        e in prop::array::uniform3(-60.0f64..60.0),
        persp in any::<bool>(),
        d in 1u32..5,
    ) {
        prop_assume!(e.iter().map(|x| x * x).sum::<f64>() > 1.0);
        let cam = if persp {
            format!("eye = [{}, {}, {}]\ntarget = [0.3, 0.2, 0.1]\nup = [0.2, 0.3, 1]\nprojection = \"perspective\"\nfov_y_deg = 70", e[0], e[1], e[2])
        } else {
            format!("eye = [{}, {}, {}]\ntarget = [0.3, 0.2, 0.1]\nup = [0.2, 0.3, 1]\nprojection = \"orthographic\"\nheight = 50", e[0], e[1], e[2])
        };
        let inp = seam_input(&cam, 24);
        let view = inp.scene.camera.view(24, 24);
        check_rays(&view, &inp, d)?;
    }
}

#[test]
fn placement_round_robin_and_balanced() {
    assert_eq!(
        place(8, 4, BrickPlacement::RoundRobin, &[0; 8]),
        vec![vec![0, 4], vec![1, 5], vec![2, 6], vec![3, 7]]
    );
    let w = [10, 1, 1, 1, 9, 1, 1, 0];
    let p = place(8, 2, BrickPlacement::Balanced, &w);
    let load: Vec<u64> = p
        .iter()
        .map(|v| v.iter().map(|&b| w[b as usize]).sum())
        .collect();
    assert_eq!(load.iter().sum::<u64>(), 24);
    assert!(
        load.iter().max().unwrap() - load.iter().min().unwrap() <= 1,
        "{load:?}"
    );
    assert!(split([2, 5, 5], 2).is_err());
}
