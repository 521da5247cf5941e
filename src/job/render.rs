//! `pvrsim render`: one scene, one image.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};

use super::memory::{self, FrameKind};

use super::validate::{self, at_least, Checks, Validate};
use crate::render::cell::ert::EntrySize;
use crate::render::cell::{
    self, CellOptions, CellOrder, ErtOptions, ErtSpan, ErtStructure, Integrator,
};
use crate::render::{reference, RenderInput};

/// Which renderer draws the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RendererKind {
    /// Cell projection with ray-segment lists (fast; the paper's algorithm).
    Cell,
    /// The f64 oracle (slow): ray walking with adaptive quadrature through
    /// the mesh, or through the voxel cells of a grid.
    Reference,
    /// Regular grids: view-aligned slices through a 3D texture (trilinear).
    Slice3d,
    /// Regular grids: object-aligned slices (bilinear), per-slice LOD.
    Slice2d,
    /// Regular grids: slice3d over adaptive blocks (`--blocks B`, b^3
    /// blocks halved while their RMS error <= `--tolerance` x the scalar
    /// range); prints the size ratio, the preprocessing time and the image
    /// error against full-resolution slice3d and the grid reference.
    Adaptive,
    /// Regular grids: EWA splatting, `--order axis|dda|sort|radix`.
    Splat,
}

/// Options of `pvrsim render`.
#[derive(Debug, Clone, Args)]
pub struct RenderArgs {
    /// Scene file (TOML, see the scene contract).
    pub scene: PathBuf,
    /// Output PNG.
    #[arg(short, long, default_value = "out.png")]
    pub output: PathBuf,
    /// Renderer. Default: picked from the data, `cell` for a tetrahedral
    /// mesh, `slice3d` for a regular grid.
    #[arg(long, value_enum)]
    pub renderer: Option<RendererKind>,
    /// Grids: classify after interpolating the scalar (`post`, the scene
    /// contract's field; default), classify voxels into an RGBA8 texture and
    /// interpolate that (`pre`, as the papers' hardware did), or integrate
    /// the transfer function between consecutive samples (`preint`, slice3d
    /// only: pre-integrated, for label volumes with step transfer functions).
    #[arg(long, value_enum)]
    pub classify: Option<crate::render::slicing::Classify>,
    /// Grids: the slicers' compositing order (`front-to-back`, default,
    /// with ERT; `back-to-front` blends with (1, 1 - A_s) as the paper), or
    /// splatting's visit order (`axis`, `dda` default, `sort`, `radix`).
    #[arg(long, value_enum)]
    pub order: Option<super::render_splat::GridOrder>,
    /// Grids (slice3d): number of view-aligned slices across the volume's
    /// depth. Default: one per voxel layer a ray along the view direction
    /// crosses (the papers' largest dimension for an axis-aligned view).
    #[arg(long, value_name = "N", conflicts_with = "spacing")]
    pub slices: Option<u64>,
    /// Grids (slice3d): distance between slices, world units.
    #[arg(long, value_name = "DELTA")]
    pub spacing: Option<f64>,
    /// Grids (--renderer adaptive): blocks per axis b (b^3 blocks) [default: 8].
    #[arg(long, value_name = "B")]
    pub blocks: Option<u64>,
    /// Grids (--renderer adaptive): a block is halved while its RMS error
    /// against the original stays <= T x the scalar range R of the transfer
    /// function (the paper's 5 %) [default: 0.05].
    #[arg(long, value_name = "T")]
    pub tolerance: Option<f64>,
    /// Grids (slice2d): per-slice level of detail, D = distance from the eye
    /// to the projection plane (world units): slice x at distance d_x gets
    /// R_org / 2^floor(log2(d_x / D)). Default: off (full resolution).
    #[arg(long, value_name = "D")]
    pub lod: Option<f64>,
    /// Grids (slicers): do not skip transparent min-max blocks.
    #[arg(long)]
    pub no_empty_skip: bool,
    /// Segment integrator of the cell renderer: `exact` (closed form per
    /// transfer-function piece, within 1e-4) or `midpoint` (one lookup).
    #[arg(long, value_enum, default_value_t = Integrator::Exact)]
    pub integrator: Integrator,
    /// Order in which cells are scan-converted.
    #[arg(long, value_enum, default_value_t = CellOrder::FrontToBack)]
    pub cell_order: CellOrder,
    /// Store every segment instead of merging touching ones on insertion.
    #[arg(long)]
    pub no_partial_composition: bool,
    /// Merge touching segments in a canonical order so the image does not
    /// depend on how cells are distributed (tiles, cluster nodes); costs list
    /// memory. Without ERT the image is then bit for bit `pvrsim cluster`'s.
    #[arg(long)]
    pub canonical: bool,
    /// Screen tile edge in pixels, at least 1 (work unit of the threads). Without ERT the
    /// image does not depend on it; with ERT each tile has its own ERT table
    /// (or pyramid), the tile is rounded to whole entries, and the image may
    /// change with it (within the ERT error bound). Never with the thread count.
    #[arg(long, default_value_t = 32)]
    pub tile: u32,
    /// Early ray termination threshold, in (0, 1]: a pixel terminates where
    /// the alpha of the segments known in front reaches it. 1.0 turns ERT off
    /// (no test, no update). Default 0.99 as in the scene contract (and
    /// `pvrsim cluster`); the paper's experiments use 0.9. The per-pixel
    /// error bound (1 - THRESHOLD) x max emitted radiance is in the stats.
    #[arg(
        long = "ert",
        value_name = "THRESHOLD",
        default_value_t = 0.99,
        allow_negative_numbers = true
    )]
    pub ert: f32,
    /// ERT table of D x D entries (flat structure; entries of ceil(W/D) x
    /// ceil(H/D) pixels; for the pyramid: its level-0 blocks). Default: 20 for
    /// `flat` (the paper's best), 1-pixel blocks for `pyramid`.
    #[arg(long, value_name = "D", conflicts_with = "ert_entry_px")]
    pub ert_table: Option<u32>,
    /// ERT entry (pyramid: level-0 block) size in pixels, N x N; alternative to --ert-table.
    #[arg(long, value_name = "N")]
    pub ert_entry_px: Option<u32>,
    /// ERT update constant C: rebuild the ERT structure after every
    /// (remaining cells)/C cells of a tile (the paper's best: 100).
    #[arg(long, value_name = "C", default_value_t = 100)]
    pub ert_update: u32,
    /// Flat ERT table: test only cells inside one entry (`single`, the paper)
    /// or also cells spanning entries (`multi`: all covered entries terminated
    /// with max deepest < nearest). Ignored by the pyramid.
    #[arg(long, value_enum, default_value_t = ErtSpan::Multi)]
    pub ert_span: ErtSpan,
    /// ERT structure: the paper's `flat` D x D table, or a max-`pyramid` over
    /// per-pixel termination depths (each cell tested on at most 2 x 2 entries).
    #[arg(long, value_enum, default_value_t = ErtStructure::Pyramid)]
    pub ert_structure: ErtStructure,
    /// Also run the ERT oracle (a second pass, ERT and partial composition
    /// off): cells and segments behind the final termination depths, and the
    /// share of the oracle's cells that ERT skipped.
    #[arg(long)]
    pub oracle: bool,
    /// Worker threads; 0 = all cores. `--threads 1` gives the same image.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Override the scene's image width (keeps the camera).
    #[arg(long, requires = "height")]
    pub width: Option<u32>,
    /// Override the scene's image height.
    #[arg(long, requires = "width")]
    pub height: Option<u32>,
    /// Write the statistics as JSON to this file.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Also render with the reference renderer, print the error of this image
    /// against it (max-abs and RMSE in 1/255) and whether it is within the
    /// bound that applies (exact integrator 2/255, plus ERT's
    /// (1 - THRESHOLD) x max radiance), and write OUTPUT-compare.png
    /// (labelled: this image | reference | 10x difference).
    #[arg(long)]
    pub compare: bool,
}

/// What one render produced.
pub struct RenderOutcome {
    /// The image.
    pub image: crate::image::Image,
    /// Every statistic, as the `--stats` JSON holds them.
    pub stats: serde_json::Value,
}

impl Validate for RenderArgs {
    fn validate(&self, c: &mut Checks) -> anyhow::Result<()> {
        let ert = validate::ert_mode(self.ert)?;
        at_least("--tile", self.tile, 1)?;
        at_least("--ert-update", self.ert_update, 1)?;
        if let Some(d) = self.ert_table {
            at_least("--ert-table", d, 1)?;
        }
        if let Some(n) = self.ert_entry_px {
            at_least("--ert-entry-px", n, 1)?;
        }
        validate::image_size(self.width, self.height)?;
        crate::budget::threads("--threads", self.threads)?;
        crate::budget::slices("--slices", self.slices.unwrap_or(0))?;
        let cell_only = [
            ("--ert-table", self.ert_table.is_some()),
            ("--ert-entry-px", self.ert_entry_px.is_some()),
            ("--oracle", self.oracle),
            ("--canonical", self.canonical),
            ("--no-partial-composition", self.no_partial_composition),
        ];
        match self.renderer.unwrap_or(RendererKind::Cell) {
            RendererKind::Reference => {
                for (flag, given) in cell_only {
                    if given {
                        c.ignored(
                            flag,
                            "the reference renderer has no ERT, tiles or segment lists",
                        );
                    }
                }
                if self.compare {
                    c.ignored("--compare", "--renderer reference is the reference itself");
                }
            }
            RendererKind::Cell if !ert.is_on() => {
                for (flag, given) in &cell_only[..2] {
                    if *given {
                        c.ignored(flag, "ERT is off (--ert 1); give --ert < 1, e.g. 0.9");
                    }
                }
            }
            RendererKind::Cell
            | RendererKind::Slice3d
            | RendererKind::Slice2d
            | RendererKind::Adaptive
            | RendererKind::Splat => {}
        }
        Ok(())
    }
}

/// The path of the `--compare` strip: `OUTPUT-compare.png`.
pub fn compare_path(output: &std::path::Path) -> PathBuf {
    output.with_file_name(format!(
        "{}-compare.png",
        output.file_stem().unwrap_or_default().to_string_lossy()
    ))
}

/// Renders as `pvrsim render` would, without writing files or printing
/// (when `quiet`). Used by `render` and by `sweep`, so that a sweep can vary
/// any option `render` has, under the same name.
pub fn execute(a: &RenderArgs, quiet: bool) -> anyhow::Result<RenderOutcome> {
    validate::check(a)?;
    let scene = crate::scene::Scene::load(&a.scene)
        .with_context(|| format!("cannot load scene {}", a.scene.display()))?;
    if super::render_grid::is_grid_scene(&scene) {
        return super::render_grid::execute(a, scene, quiet);
    }
    refuse_grid_options(a)?;
    let (mut input, load_s) = RenderInput::load(&a.scene)
        .with_context(|| format!("cannot load scene {}", a.scene.display()))?;
    if let (Some(w), Some(h)) = (a.width, a.height) {
        input = input.with_size(w, h);
    }
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
        memory::available_bytes(),
    )?;
    if !quiet {
        super::warn_field(&input);
    }
    let opts = CellOptions {
        integrator: a.integrator,
        partial_composition: !a.no_partial_composition,
        tile_size: a.tile,
        cell_order: a.cell_order,
        ert: ErtOptions {
            threshold: a.ert,
            entry: a
                .ert_entry_px
                .map(EntrySize::Pixels)
                .or(a.ert_table.map(EntrySize::Divisions)),
            update_c: a.ert_update,
            span: a.ert_span,
            structure: a.ert_structure,
        },
        oracle: a.oracle,
        canonical: a.canonical,
    };
    let (image, mut stats) = match a.renderer.unwrap_or(RendererKind::Cell) {
        RendererKind::Slice3d
        | RendererKind::Slice2d
        | RendererKind::Adaptive
        | RendererKind::Splat => {
            unreachable!("refused above")
        }
        RendererKind::Cell => {
            let (image, mut stats) =
                super::with_threads(a.threads, || cell::render(&input, &opts))?;
            stats.time_load_s = load_s;
            stats.time_total_s += load_s;
            if !quiet {
                print_cell_summary(a, &input, &stats);
            }
            (image, serde_json::to_value(&stats)?)
        }
        RendererKind::Reference => {
            let adjacency = input.mesh.adjacency();
            let (image, stats) = super::with_threads(a.threads, || {
                reference::render(&input, &adjacency, &Default::default())
            })?;
            if !quiet {
                println!(
                    "reference render of {}: {}x{} in {:.3} s (load {:.3} s)",
                    a.scene.display(),
                    image.width,
                    image.height,
                    stats.time_s,
                    load_s
                );
            }
            (image, serde_json::to_value(&stats)?)
        }
    };
    anyhow::ensure!(
        !image.has_non_finite(),
        "internal error: the image has NaN or infinite pixels"
    );
    if a.compare && a.renderer.unwrap_or(RendererKind::Cell) == RendererKind::Cell {
        let adjacency = input.mesh.adjacency();
        let (reference, rs) = super::with_threads(a.threads, || {
            reference::render(&input, &adjacency, &Default::default())
        })?;
        let err = image.error_against(&reference);
        let ert_bound = stats["ert_error_bound"].as_f64().unwrap_or(0.0);
        let v = super::compare::verdict(&err, a.integrator, ert_bound);
        stats["error_vs_reference"] = serde_json::to_value(err)?;
        stats["compare_verdict"] = serde_json::to_value(&v)?;
        stats["reference_time_s"] = serde_json::to_value(rs.time_s)?;
        if !quiet {
            println!("against the reference ({:.2} s): {err}", rs.time_s);
            println!("{}", v.text);
            let path = compare_path(&a.output);
            let label = format!("this: cell ({})", a.integrator_name());
            super::compare::write_strip(&image, &reference, &label, 10.0, &path)?;
            println!(
                "wrote {} (labelled: this | reference | 10x difference)",
                path.display()
            );
        }
    }
    Ok(RenderOutcome { image, stats })
}

impl RenderArgs {
    fn integrator_name(&self) -> String {
        self.integrator
            .to_possible_value()
            .map(|v| v.get_name().to_string())
            .unwrap_or_default()
    }
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
            )
        ) && a.blocks.is_none()
            && a.tolerance.is_none(),
        "--renderer slice3d/slice2d/adaptive/splat (and --blocks, --tolerance) draw regular grids; scene {} renders a tetrahedral mesh \
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

fn print_cell_summary(a: &RenderArgs, input: &RenderInput, s: &cell::CellStats) {
    let sc = &input.scene.image;
    println!(
        "cell projection of {} ({}x{}, {} integrator, {} order, partial composition {}, {})",
        a.scene.display(),
        sc.width,
        sc.height,
        s.integrator,
        s.cell_order,
        if s.partial_composition { "on" } else { "off" },
        super::plural(s.threads, "thread")
    );
    println!(
        "  cells: {} total, {} culled empty, {} culled off-screen, {} projected",
        s.cells_total, s.cells_culled_empty, s.cells_culled_offscreen, s.cells_projected
    );
    println!(
        "  segments: {} generated, {} merged by partial composition; lists: mean {:.2}, max {}",
        s.segments_generated, s.segments_merged, s.list_len_mean, s.list_len_max
    );
    let rate = |n: u64| {
        if s.time_scan_s > 0.0 {
            n as f64 / s.time_scan_s / 1e6
        } else {
            0.0
        }
    };
    println!(
        "  time: load {:.3} s, project {:.3} s, scan {:.3} s ({:.2} M segments/s, {:.2} M cells/s), composite {:.3} s, total {:.3} s",
        s.time_load_s,
        s.time_project_s,
        s.time_scan_s,
        rate(s.segments_generated),
        rate(s.cells_projected),
        s.time_composite_s,
        s.time_total_s
    );
    if s.ert_threshold < 1.0 {
        println!(
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
        );
    }
    if let (Some(sk), Some(n), Some(sb)) = (
        s.oracle_cells_skippable,
        s.oracle_cells_considered,
        s.oracle_segments_behind_share,
    ) {
        println!(
            "  oracle: {} of {} cells skippable ({:.1} %), {:.1} % of segments behind termination; ERT skipped {:.1} % of the oracle's cells ({:.2} s)",
            sk,
            n,
            100.0 * sk as f64 / n.max(1) as f64,
            100.0 * sb,
            100.0 * s.ert_share_of_oracle.unwrap_or(0.0),
            s.oracle_time_s.unwrap_or(0.0)
        );
    }
}
