//! `pvrsim render SCENE --renderer splat --order axis|dda|sort` (issue 11):
//! EWA splatting of a grid scene through the common `render` command (same
//! output, `--stats`, `--compare`, `--threads`, `--width/--height`, `--ert`
//! as the slicers: `--ert` is the early splat elimination threshold, and
//! its bound `ert_error_bound` is in the stats). `--order` is shared with the slicers
//! ([`GridOrder`]).

use crate::image::Image;
use crate::job::grid_order::GridOrder;
use crate::job::render::RenderArgs;
use crate::render::splat::{render_splat, SplatOptions};
use crate::render::VolumeInput;

/// Refuses slicer options for the splat renderer (never silently ignored).
pub fn refuse_slicer_options(a: &RenderArgs) -> anyhow::Result<()> {
    let mut bad = Vec::new();
    if a.classify.is_some() {
        bad.push("--classify (splats classify their samples before drawing)");
    }
    if a.slices.is_some() || a.spacing.is_some() {
        bad.push("--slices/--spacing");
    }
    if a.lod.is_some() {
        bad.push("--lod");
    }
    if a.no_empty_skip {
        bad.push("--no-empty-skip (splatting culls transparent voxels by definition)");
    }
    anyhow::ensure!(
        bad.is_empty(),
        "{} do(es) not apply to --renderer splat",
        bad.join(", ")
    );
    Ok(())
}

/// Renders `input` by splatting; returns the image and the stats JSON, and
/// adds the lines `pvrsim render` prints to `say`.
pub fn render(
    a: &RenderArgs,
    input: &VolumeInput,
    say: &mut Vec<String>,
) -> anyhow::Result<(Image, serde_json::Value)> {
    refuse_slicer_options(a)?;
    crate::job::validate::ert_mode(a.ert.threshold)?;
    let opts = SplatOptions {
        order: GridOrder::splat(a.order)?,
        // Early splat elimination at the common ERT threshold (1: off).
        ert: a.ert.threshold,
        ..Default::default()
    };
    let (img, st) = crate::job::with_threads(a.threads, || render_splat(input, &opts))??;
    say.push(format!(
        "splat of {} ({}x{}, order {}): {} of {} voxels drawn (fill rate {:.4}), \
         order {:.1} ms, splat {:.1} ms",
        a.scene.display(),
        img.width,
        img.height,
        st.order,
        st.voxels_drawn,
        st.voxels_total,
        st.fill_rate,
        st.order_ms,
        st.splat_ms
    ));

    let mut v = serde_json::to_value(&st)?;
    v["renderer"] = serde_json::json!("splat");
    v["time_render_s"] = serde_json::json!((st.order_ms + st.splat_ms) * 1e-3);
    v["time_total_s"] = v["time_render_s"].clone();
    Ok((img, v))
}
