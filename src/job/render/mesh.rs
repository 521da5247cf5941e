//! `pvrsim render` on a tetrahedral mesh: cell projection with ray-segment
//! lists (`--renderer cell`, default) or the f64 reference walk, with
//! `--compare`'s verdict and strip.

use anyhow::Context;

use crate::job::memory::{self, FrameKind};
use crate::job::render::{compare_path, RenderArgs, RenderOutcome, RendererKind};
use crate::job::validate::Valid;
use crate::render::cell::ert::EntrySize;
use crate::render::cell::{self, CellOptions, ErtOptions};
use crate::render::{reference, RenderInput};
use crate::scene::Scene;

/// Renders a mesh scene (cell projection or the f64 reference; `scene`
/// read once by the caller, the mesh read here), without writing files or
/// warning (when `quiet`); [`crate::job::run`] hands mesh scenes here.
pub fn execute(
    v: &Valid<'_, RenderArgs>,
    scene: Scene,
    quiet: bool,
) -> anyhow::Result<RenderOutcome> {
    let (input, load_s) = load(v.args(), scene, quiet)?;
    render(v, &input, load_s, quiet)
}

/// Reads the mesh of `scene` for the options `a` (the image size
/// `--width`/`--height` applied, the field reported unless `quiet`, the
/// other fields released): the input [`render`] draws, any number of times.
pub fn load(a: &RenderArgs, scene: Scene, quiet: bool) -> anyhow::Result<(RenderInput, f64)> {
    let (mut input, load_s) = load_keeping_fields(a, scene, quiet)?;
    input.release_fields();
    Ok((input, load_s))
}

/// [`load`] with every point field of the mesh kept (a live view switches
/// between them).
pub fn load_keeping_fields(
    a: &RenderArgs,
    scene: Scene,
    quiet: bool,
) -> anyhow::Result<(RenderInput, f64)> {
    refuse_grid_options(a)?;
    let (mut input, load_s) = RenderInput::read(scene)
        .with_context(|| format!("cannot load scene {}", a.scene.display()))?;
    if let (Some(w), Some(h)) = (a.width, a.height) {
        input = input.with_size(w, h);
    }
    if !quiet {
        crate::job::warn_field(&input);
    }
    Ok((input, load_s))
}

/// Renders a loaded mesh input (its scene's camera, transfer function and
/// image size) with the validated options `v`, as `pvrsim render` does
/// after loading.
pub fn render(
    v: &Valid<'_, RenderArgs>,
    input: &RenderInput,
    load_s: f64,
    quiet: bool,
) -> anyhow::Result<RenderOutcome> {
    let a = v.args();
    let threads = if a.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        a.threads
    };
    let kind = FrameKind::Render {
        tile: a.tile,
        threads,
        compare: a.compare,
    };
    memory::check_fits(
        input.scene.image.width,
        input.scene.image.height,
        kind,
        crate::budget::available_bytes(),
    )?;
    let mut say = Vec::new();
    let opts = CellOptions {
        integrator: a.integrator,
        partial_composition: !a.no_partial_composition,
        tile_size: a.tile,
        cell_order: a.cell_order,
        ert: ErtOptions {
            mode: v.parsed().ert,
            entry: a
                .ert_entry_px
                .map(EntrySize::Pixels)
                .or(a.ert_table.map(EntrySize::Divisions)),
            update_c: a.ert_update,
            span: a.ert_span,
            structure: a.ert_structure,
            backoff: true,
        },
        oracle: a.oracle,
        canonical: a.canonical,
    };
    let (image, mut stats) = match a.renderer.unwrap_or(RendererKind::Cell) {
        RendererKind::Slice3d
        | RendererKind::Slice2d
        | RendererKind::Adaptive
        | RendererKind::Splat
        | RendererKind::ShearWarp => {
            unreachable!("refused above")
        }
        RendererKind::Cell => {
            let (image, mut stats) =
                crate::job::with_threads(a.threads, || cell::render(input, &opts))?;
            stats.time_load_s = load_s;
            stats.time_total_s += load_s;
            let peak = crate::net::cpu::peak_rss_bytes();
            cell_summary(a, input, &stats, peak, &mut say);
            let mut v = serde_json::to_value(&stats)?;
            v["peak_rss_bytes"] = serde_json::to_value(peak)?;
            (image, v)
        }
        RendererKind::Reference => {
            let adjacency = input.mesh.adjacency();
            let (image, stats) = crate::job::with_threads(a.threads, || {
                reference::render(input, &adjacency, &Default::default())
            })?;
            say.push(format!(
                "reference render of {}: {}x{} in {:.3} s (load {:.3} s)",
                a.scene.display(),
                image.width,
                image.height,
                stats.time_s,
                load_s
            ));
            (image, serde_json::to_value(&stats)?)
        }
    };
    anyhow::ensure!(
        !image.has_non_finite(),
        "internal error: the image has NaN or infinite pixels"
    );
    if a.compare && a.renderer.unwrap_or(RendererKind::Cell) == RendererKind::Cell {
        let adjacency = input.mesh.adjacency();
        let (reference, rs) = crate::job::with_threads(a.threads, || {
            reference::render(input, &adjacency, &Default::default())
        })?;
        let err = image.error_against(&reference);
        let ert_bound = stats["ert_error_bound"].as_f64().unwrap_or(0.0);
        let v = crate::job::compare::verdict(&err, a.integrator, ert_bound);
        stats["error_vs_reference"] = serde_json::to_value(err)?;
        stats["compare_verdict"] = serde_json::to_value(&v)?;
        stats["reference_time_s"] = serde_json::to_value(rs.time_s)?;
        say.push(format!("against the reference ({:.2} s): {err}", rs.time_s));
        say.push(v.text.clone());
        if !quiet {
            let path = compare_path(&a.output);
            let label = format!("this: cell ({})", a.integrator_name());
            crate::job::compare::write_strip(&image, &reference, &label, 10.0, &path)?;
            say.push(format!(
                "wrote {} (labelled: this | reference | 10x difference)",
                path.display()
            ));
        }
    }
    Ok(RenderOutcome {
        image,
        stats,
        summary: say,
    })
}

/// Grid-only options given for a mesh: refused, never silently ignored.
fn refuse_grid_options(a: &RenderArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        !matches!(
            a.renderer,
            Some(
                RendererKind::Slice3d
                    | RendererKind::Slice2d
                    | RendererKind::Adaptive
                    | RendererKind::Splat
                    | RendererKind::ShearWarp
            )
        ) && a.blocks.is_none()
            && a.tolerance.is_none(),
        "--renderer slice3d/slice2d/adaptive/splat/shearwarp (and --blocks, --tolerance) draw regular grids; scene {} renders a tetrahedral mesh \
         (use cell or reference)",
        a.scene.display()
    );
    anyhow::ensure!(
        a.classify.is_none()
            && a.order.is_none()
            && a.slices.is_none()
            && a.spacing.is_none()
            && a.lod.is_none()
            && !a.no_empty_skip,
        "--classify, --order, --slices, --spacing, --lod and --no-empty-skip apply to regular \
         grids only; scene {} renders a tetrahedral mesh",
        a.scene.display()
    );
    Ok(())
}

/// The lines `pvrsim render` prints about a cell-projection frame.
fn cell_summary(
    a: &RenderArgs,
    input: &RenderInput,
    s: &cell::CellStats,
    peak_rss: Option<u64>,
    say: &mut Vec<String>,
) {
    let sc = &input.scene.image;
    say.push(format!(
        "cell projection of {} ({}x{}, {} integrator, {} order, partial composition {}, {})",
        a.scene.display(),
        sc.width,
        sc.height,
        s.integrator,
        s.cell_order,
        if s.partial_composition { "on" } else { "off" },
        crate::job::plural(s.threads, "thread")
    ));
    say.push(format!(
        "  cells: {} total, {} culled empty, {} culled off-screen, {} projected",
        s.cells_total, s.cells_culled_empty, s.cells_culled_offscreen, s.cells_projected
    ));
    say.push(format!(
        "  segments: {} generated, {} merged by partial composition; lists: mean {:.2}, max {}",
        s.segments_generated, s.segments_merged, s.list_len_mean, s.list_len_max
    ));
    let rate = |n: u64| {
        if s.time_scan_s > 0.0 {
            n as f64 / s.time_scan_s / 1e6
        } else {
            0.0
        }
    };
    say.push(format!(
        "  time: load {:.3} s, project {:.3} s, scan {:.3} s ({:.2} M segments/s, {:.2} M cells/s), composite {:.3} s, total {:.3} s",
        s.time_load_s,
        s.time_project_s,
        s.time_scan_s,
        rate(s.segments_generated),
        rate(s.cells_projected),
        s.time_composite_s,
        s.time_total_s
    ));
    let per_tet = |b: u64| b as f64 / s.cells_total.max(1) as f64;
    say.push(format!(
        "  memory: mesh {} ({:.1} B a tetrahedron), frame {} ({:.1} B){}",
        crate::budget::human(s.mesh_bytes),
        per_tet(s.mesh_bytes),
        crate::budget::human(s.frame_bytes),
        per_tet(s.frame_bytes),
        peak_rss.map_or(String::new(), |p| format!(
            "; peak resident {} ({:.1} B a tetrahedron)",
            crate::budget::human(p),
            per_tet(p)
        ))
    ));
    if s.ert_threshold < 1.0 {
        say.push(format!(
            "  ERT: threshold {}, {} {}{}x{} px entries, C {}: {} cells skipped ({} cell-tile pairs), {} updates {:.3} s, {} tests {:.3} s, overhead {:.1} % of scan (phase {:.3} s), error bound {:.4}",
            s.ert_threshold,
            s.ert_structure,
            if s.ert_span.is_empty() { String::new() } else { format!("{} ", s.ert_span) },
            s.ert_entry_px[0],
            s.ert_entry_px[1],
            s.ert_update_c,
            s.cells_skipped_ert,
            s.cell_tile_pairs_skipped_ert,
            s.ert_updates,
            s.ert_update_s,
            s.ert_tests,
            s.ert_tests_s,
            100.0 * s.ert_overhead_share,
            s.time_scan_phase_s,
            s.ert_error_bound
        ));
    }
    if let (Some(sk), Some(n), Some(sb)) = (
        s.oracle_cells_skippable,
        s.oracle_cells_considered,
        s.oracle_segments_behind_share,
    ) {
        say.push(format!(
            "  oracle: {} of {} cells skippable ({:.1} %), {:.1} % of segments behind termination; ERT skipped {:.1} % of the oracle's cells ({:.2} s)",
            sk,
            n,
            100.0 * sk as f64 / n.max(1) as f64,
            100.0 * sb,
            100.0 * s.ert_share_of_oracle.unwrap_or(0.0),
            s.oracle_time_s.unwrap_or(0.0)
        ));
    }
}
