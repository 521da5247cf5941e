//! `pvrsim render` for regular grids: the grid reference, `slice3d` and
//! `slice2d`. [`render`](crate::job::render) hands a scene over here when its
//! data file is a volume; this file owns the grid options' meaning.

use std::sync::Arc;

use anyhow::Context;

use crate::image::Image;
use crate::job::grid_order::GridOrder;
use crate::job::render::{RenderArgs, RenderOutcome, RendererKind};
use crate::render::adaptive::{self, AdaptiveOptions};
use crate::render::cell::{CellOrder, ErtSpan, ErtStructure, Integrator};
use crate::render::shearwarp::{self, ShearWarpOptions};
use crate::render::slice2d::{self, Slice2dOptions};
use crate::render::slice3d::{self, Slice3dOptions, SliceCount};
use crate::render::slicing::Classify;
use crate::render::{grid_reference, VolumeInput};
use crate::scene::Scene;

/// True when the scene's data file is not a mesh (so a volume reader owns it).
pub fn is_grid_scene(scene: &Scene) -> bool {
    !crate::data::dataset::is_mesh_file(&scene.data.path)
}

/// Loads the volume of a scene; returns the input and the load seconds.
pub fn load(a: &RenderArgs, scene: Scene) -> anyhow::Result<(VolumeInput, f64)> {
    let t = std::time::Instant::now();
    let vol = crate::data::io::read_volume(&scene.data.path, &scene.data.field)
        .with_context(|| format!("cannot load the volume of scene {}", a.scene.display()))?;
    let load_s = t.elapsed().as_secs_f64();
    let mut input = VolumeInput::new(scene, Arc::new(vol))?;
    if let (Some(w), Some(h)) = (a.width, a.height) {
        anyhow::ensure!(w > 0 && h > 0, "--width and --height must be > 0");
        input = input.with_size(w, h);
    }
    Ok((input, load_s))
}

/// Mesh-only options given for a grid: refused, never silently ignored.
fn refuse_mesh_options(a: &RenderArgs) -> anyhow::Result<()> {
    // Options with defaults are refused when they differ from the default
    // (an explicit default changes nothing either way).
    let mut bad = Vec::new();
    if a.integrator != Integrator::Exact {
        bad.push("--integrator");
    }
    if a.cell_order != CellOrder::FrontToBack {
        bad.push("--cell-order");
    }
    if a.no_partial_composition {
        bad.push("--no-partial-composition");
    }
    if a.canonical {
        bad.push("--canonical");
    }
    if a.tile != 32 {
        bad.push("--tile");
    }
    if a.ert_table.is_some() || a.ert_entry_px.is_some() || a.ert_update != 100 {
        bad.push("--ert-table/--ert-entry-px/--ert-update");
    }
    if a.ert_span != ErtSpan::Multi || a.ert_structure != ErtStructure::Pyramid {
        bad.push("--ert-span/--ert-structure");
    }
    if a.oracle {
        bad.push("--oracle");
    }
    anyhow::ensure!(
        bad.is_empty(),
        "{} appl{} to tetrahedral meshes only; scene {} renders a regular grid",
        bad.join(", "),
        if bad.len() == 1 { "ies" } else { "y" },
        a.scene.display()
    );
    Ok(())
}

/// The slice count of the options.
fn slice_count(a: &RenderArgs) -> SliceCount {
    match (a.slices, a.spacing) {
        (Some(n), _) => SliceCount::Count(n),
        (None, Some(d)) => SliceCount::Spacing(d),
        (None, None) => SliceCount::Default,
    }
}

fn slice3d_options(a: &RenderArgs) -> anyhow::Result<Slice3dOptions> {
    Ok(Slice3dOptions {
        classify: a.classify.unwrap_or(Slice3dOptions::default().classify),
        order: GridOrder::compositing(a.order)?,
        ert: a.ert.threshold,
        slices: slice_count(a),
        empty_skip: !a.no_empty_skip,
        brick: None,
    })
}

/// `--blocks` and `--tolerance` with their defaults.
pub fn adaptive_options(a: &RenderArgs) -> AdaptiveOptions {
    let d = AdaptiveOptions::default();
    AdaptiveOptions {
        blocks: a.blocks.unwrap_or(d.blocks),
        tolerance: a.tolerance.unwrap_or(d.tolerance),
    }
}

fn slice2d_options(a: &RenderArgs) -> anyhow::Result<Slice2dOptions> {
    Ok(Slice2dOptions {
        classify: a.classify.unwrap_or(Classify::Post),
        order: GridOrder::compositing(a.order)?,
        ert: a.ert.threshold,
        lod: a.lod,
        empty_skip: !a.no_empty_skip,
    })
}

/// True when an option that only slice3d (and adaptive) reads is given:
/// `--slices`, `--spacing`, `--classify`, `--order`.
fn slicer_options_given(a: &RenderArgs) -> bool {
    a.slices.is_some() || a.spacing.is_some() || a.classify.is_some() || a.order.is_some()
}

/// The grid renderer when `--renderer` is not given: **shear-warp** for an
/// orthographic view it can draw whose final pixels are at least as large
/// as the voxels (the fastest: one bilinear sample per voxel slice over
/// run-length encoded slices, RMSE against the f64 grid reference below
/// VolPack's, see docs/experiments/shearwarp.md), **slice3d** otherwise: a
/// perspective camera, a volume reaching behind the eye plane, a magnified
/// view (voxels larger than pixels: the warp would blur them over several
/// pixels, [`shearwarp::warp_scale`] < 1), or one of slice3d's own options
/// given (`--slices`, `--spacing`, `--classify`, `--order`). slice3d
/// samples every pixel's own ray: at hard silhouettes its max-abs error is
/// several times lower than the warp's.
pub fn default_renderer(a: &RenderArgs, input: &VolumeInput) -> RendererKind {
    let sw = ShearWarpOptions {
        ert: a.ert.threshold,
        empty_skip: !a.no_empty_skip,
    };
    if slicer_options_given(a)
        || shearwarp::check(input, &sw).is_err()
        || shearwarp::warp_scale(input) < 1.0
    {
        RendererKind::Slice3d
    } else {
        RendererKind::ShearWarp
    }
}

/// Renders a grid scene as `pvrsim render` does.
pub fn execute(a: &RenderArgs, scene: Scene, quiet: bool) -> anyhow::Result<RenderOutcome> {
    let (input, load_s) = load_checked(a, scene)?;
    render(a, &input, load_s, quiet)
}

/// Checks the grid options against each other and loads the volume of
/// `scene`: the input [`render`] draws, any number of times.
pub fn load_checked(a: &RenderArgs, scene: Scene) -> anyhow::Result<(VolumeInput, f64)> {
    refuse_mesh_options(a)?;
    // Before the volume is loaded, an unset renderer is checked as slice3d
    // when slice3d's options are given, else as shear-warp (which takes
    // none of the slicers' options); after loading it is settled.
    let kind = a.renderer.unwrap_or(if slicer_options_given(a) {
        RendererKind::Slice3d
    } else {
        RendererKind::ShearWarp
    });
    anyhow::ensure!(
        kind != RendererKind::Cell,
        "--renderer cell draws tetrahedral meshes; scene {} renders a regular grid \
         (use slice3d, slice2d, shearwarp or reference)",
        a.scene.display()
    );
    anyhow::ensure!(
        a.lod.is_none() || kind == RendererKind::Slice2d,
        "--lod applies to --renderer slice2d only"
    );
    anyhow::ensure!(
        a.slices.is_none() && a.spacing.is_none() && a.blocks.is_none() && a.tolerance.is_none()
            || matches!(kind, RendererKind::Slice3d | RendererKind::Adaptive),
        "--slices and --spacing apply to --renderer slice3d and adaptive only (slice2d draws \
         one slice per grid plane)"
    );
    anyhow::ensure!(
        a.blocks.is_none() && a.tolerance.is_none() || kind == RendererKind::Adaptive,
        "--blocks and --tolerance apply to --renderer adaptive only"
    );
    anyhow::ensure!(
        kind != RendererKind::Reference
            || (a.classify.is_none() && a.order.is_none() && !a.no_empty_skip),
        "--classify, --order and --no-empty-skip apply to the slicers, not the reference"
    );
    load(a, scene)
}

/// Renders a loaded grid input (its scene's camera, transfer function and
/// image size) with the options `a`, as `pvrsim render` does after loading
/// (the default renderer picked for this camera).
pub fn render(
    a: &RenderArgs,
    input: &VolumeInput,
    load_s: f64,
    quiet: bool,
) -> anyhow::Result<RenderOutcome> {
    let kind = a.renderer.unwrap_or_else(|| default_renderer(a, input));
    let mut say = Vec::new();
    if a.renderer.is_none() {
        say.push(match kind {
            RendererKind::ShearWarp => format!(
                "renderer: shearwarp (the default for an orthographic grid view with pixels at \
                 least as large as the voxels, here {:.2} voxels a pixel; --renderer slice3d \
                 samples each pixel's own ray: lower max-abs error at sharp silhouettes, slower)",
                shearwarp::warp_scale(input)
            ),
            _ => "renderer: slice3d (the default for this grid scene: a perspective or magnified \
                view, a volume behind the eye plane, or slice3d's options given)"
                .to_string(),
        });
    }
    let (image, mut stats) = render_with(a, kind, input, &mut say)?;
    stats["time_load_s"] = serde_json::json!(load_s);
    stats["mesh_keys"] = serde_json::json!(
        "absent: a regular grid has no cells, segments or lists (cells_*, segments_*, list_len_*)"
    );
    anyhow::ensure!(
        !image.has_non_finite(),
        "internal error: the image has NaN or infinite pixels"
    );
    if a.compare {
        let (reference, rs) = crate::job::with_threads(a.threads, || {
            grid_reference::render(input, &Default::default())
        })?;
        let err = image.error_against(&reference);
        stats["error_vs_reference"] = serde_json::to_value(err)?;
        stats["reference_time_s"] = serde_json::to_value(rs.time_s)?;
        say.push(format!(
            "against the grid reference ({:.2} s): {err}",
            rs.time_s
        ));
        if !quiet {
            say.push(write_compare(a, kind, &image, &reference)?);
        }
    }
    Ok(RenderOutcome {
        image,
        stats,
        summary: say,
    })
}

/// Writes the `--compare` strip; the line that says so.
fn write_compare(
    a: &RenderArgs,
    kind: RendererKind,
    image: &Image,
    reference: &Image,
) -> anyhow::Result<String> {
    let path = crate::job::render::compare_path(&a.output);
    let label = clap::ValueEnum::to_possible_value(&kind)
        .map_or("grid".to_string(), |v| v.get_name().to_string());
    crate::job::compare::write_strip(image, reference, &label, 10.0, &path)?;
    Ok(format!(
        "wrote {} ({label} | reference | 10x difference, labelled)",
        path.display()
    ))
}

/// Renders with one grid renderer; returns the image and the stats JSON,
/// and adds the lines `pvrsim render` prints to `say`.
pub fn render_with(
    a: &RenderArgs,
    kind: RendererKind,
    input: &VolumeInput,
    say: &mut Vec<String>,
) -> anyhow::Result<(Image, serde_json::Value)> {
    let vol = &input.volume;
    let name = a.scene.display();
    match kind {
        RendererKind::Reference => {
            let (img, st) = crate::job::with_threads(a.threads, || {
                grid_reference::render(input, &Default::default())
            })?;
            {
                say.push(format!(
                    "grid reference of {name}: {}x{} in {:.3} s ({} cells walked, {} skipped empty)",
                    img.width, img.height, st.time_s, st.cells_visited, st.cells_skipped_empty
                ));
            }
            let mut v = serde_json::to_value(&st)?;
            v["renderer"] = serde_json::json!("reference");
            v["voxels"] = serde_json::json!(vol.len());
            v["time_total_s"] = serde_json::json!(st.time_s);
            Ok((img, v))
        }
        RendererKind::Slice3d | RendererKind::Slice2d | RendererKind::ShearWarp => {
            let (img, st) = if kind == RendererKind::Slice3d {
                let o = slice3d_options(a)?;
                crate::job::with_threads(a.threads, || slice3d::render(input, &o))??
            } else if kind == RendererKind::ShearWarp {
                anyhow::ensure!(
                    a.classify.is_none() && a.order.is_none(),
                    "--classify and --order do not apply to --renderer shearwarp \
                     (post-classified, front to back)"
                );
                let o = ShearWarpOptions {
                    ert: a.ert.threshold,
                    empty_skip: !a.no_empty_skip,
                };
                crate::job::with_threads(a.threads, || shearwarp::render(input, &o))??
            } else {
                let o = slice2d_options(a)?;
                crate::job::with_threads(a.threads, || slice2d::render(input, &o))??
            };
            {
                let taken = st.samples_taken as f64;
                let all = taken + (st.samples_skipped_empty + st.samples_skipped_ert) as f64;
                say.push(format!(
                    "{} of {name} ({}x{}, {} classification, {} slices, spacing {:.4}, {} threads): \
                     prepare {:.3} s, frame {:.3} s",
                    st.renderer,
                    img.width,
                    img.height,
                    match st.classify {
                        Some(Classify::Pre) => "pre",
                        Some(Classify::Preint) => "pre-integrated",
                        _ => "post",
                    },
                    st.slices,
                    st.slice_spacing,
                    st.threads,
                    st.time_prepare_s,
                    st.time_render_s
                ));
                say.push(format!(
                    "  samples: {} taken ({:.1} M/s), {:.1} % skipped as empty space, {:.1} % by ERT; \
                     texture {:.1} MiB",
                    st.samples_taken,
                    taken / st.time_render_s.max(1e-12) / 1e6,
                    100.0 * st.samples_skipped_empty as f64 / all.max(1.0),
                    100.0 * st.samples_skipped_ert as f64 / all.max(1.0),
                    st.texture_bytes as f64 / (1 << 20) as f64
                ));
            }
            let mut v = serde_json::to_value(&st)?;
            v["time_total_s"] = serde_json::json!(st.time_prepare_s + st.time_render_s);
            Ok((img, v))
        }
        RendererKind::Adaptive => render_adaptive(a, input, say),
        RendererKind::Splat => crate::job::render::splat::render(a, input, say),
        RendererKind::Cell => unreachable!("refused by execute"),
    }
}

/// `--renderer adaptive`: builds the blocks, renders, and measures the
/// image error against full-resolution slice3d with the same options (the
/// grid reference is compared by `--compare`, as for every renderer).
fn render_adaptive(
    a: &RenderArgs,
    input: &VolumeInput,
    say: &mut Vec<String>,
) -> anyhow::Result<(Image, serde_json::Value)> {
    let o = slice3d_options(a)?;
    let ad = adaptive_options(a);
    let (img, st) = crate::job::with_threads(a.threads, || adaptive::render(input, &o, &ad))??;
    let (full, fst) = crate::job::with_threads(a.threads, || slice3d::render(input, &o))??;
    let err = img.error_against(&full);
    let s = &st.adaptive;
    {
        say.push(format!(
            "adaptive of {} ({}x{}, {} blocks = {}x{}x{}, tolerance {} x R = {:.4}): \
             build {:.3} s, frame {:.3} s (slice3d full: {:.3} s)",
            a.scene.display(),
            img.width,
            img.height,
            s.blocks,
            s.blocks_per_axis[0],
            s.blocks_per_axis[1],
            s.blocks_per_axis[2],
            s.tolerance,
            s.tolerance * s.range,
            s.build_s,
            st.slice.time_render_s,
            fst.time_render_s
        ));
        say.push(format!(
            "  size ratio {:.1} % ({:.2} of {:.2} MiB), blocks per level {:?}, \
             scalar RMS error {:.3} % of R (worst block {:.3} %)",
            100.0 * s.size_ratio,
            s.bytes_reduced as f64 / (1 << 20) as f64,
            s.bytes_original as f64 / (1 << 20) as f64,
            s.levels,
            100.0 * s.rms_error_rel,
            100.0 * s.max_block_rms_rel
        ));
        say.push(format!("  against full-resolution slice3d: {err}"));
    }
    let mut v = serde_json::to_value(&st)?;
    v["time_total_s"] = serde_json::json!(st.slice.time_prepare_s + st.slice.time_render_s);
    v["error_vs_slice3d"] = serde_json::to_value(err)?;
    v["slice3d_time_render_s"] = serde_json::json!(fst.time_render_s);
    Ok((img, v))
}
