//! `pvrsim render`: one scene, one image.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};

use crate::render::cell::{self, CellOptions, CellOrder, Integrator};
use crate::render::{reference, RenderInput};

/// Which renderer draws the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RendererKind {
    /// Cell projection with ray-segment lists (fast; the paper's algorithm).
    Cell,
    /// f64 ray walking with adaptive quadrature (slow; the oracle).
    Reference,
}

/// Options of `pvrsim render`.
#[derive(Debug, Clone, Args)]
pub struct RenderArgs {
    /// Scene file (TOML, see the scene contract).
    pub scene: PathBuf,
    /// Output PNG.
    #[arg(short, long, default_value = "out.png")]
    pub output: PathBuf,
    /// Renderer.
    #[arg(long, value_enum, default_value_t = RendererKind::Cell)]
    pub renderer: RendererKind,
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
    /// Screen tile edge in pixels (work unit of the threads; the image does not depend on it).
    #[arg(long, default_value_t = 32)]
    pub tile: u32,
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
    /// against it (max-abs and RMSE in 1/255), and write OUTPUT-compare.png
    /// (this image | reference | 10x difference).
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

/// Renders as `pvrsim render` would, without writing files or printing
/// (when `quiet`). Used by `render` and by `sweep`, so that a sweep can vary
/// any option `render` has, under the same name.
pub fn execute(a: &RenderArgs, quiet: bool) -> anyhow::Result<RenderOutcome> {
    let (mut input, load_s) = RenderInput::load(&a.scene)
        .with_context(|| format!("cannot load scene {}", a.scene.display()))?;
    if let (Some(w), Some(h)) = (a.width, a.height) {
        anyhow::ensure!(w > 0 && h > 0, "--width and --height must be > 0");
        input = input.with_size(w, h);
    }
    let opts = CellOptions {
        integrator: a.integrator,
        partial_composition: !a.no_partial_composition,
        tile_size: a.tile.max(1),
        cell_order: a.cell_order,
    };
    let (image, mut stats) = match a.renderer {
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
    if a.compare {
        let adjacency = input.mesh.adjacency();
        let (reference, rs) = super::with_threads(a.threads, || {
            reference::render(&input, &adjacency, &Default::default())
        })?;
        let err = image.error_against(&reference);
        stats["error_vs_reference"] = serde_json::to_value(err)?;
        stats["reference_time_s"] = serde_json::to_value(rs.time_s)?;
        if !quiet {
            println!("against the reference ({:.2} s): {err}", rs.time_s);
            let diff = crate::image::Image::difference(&image, &reference, 10.0);
            let side = crate::image::Image::side_by_side(&[&image, &reference, &diff], 4);
            let path = a.output.with_file_name(format!(
                "{}-compare.png",
                a.output.file_stem().unwrap_or_default().to_string_lossy()
            ));
            side.save_png(&path)?;
            println!(
                "wrote {} (this | reference | 10x difference)",
                path.display()
            );
        }
    }
    Ok(RenderOutcome { image, stats })
}

/// Runs `pvrsim render`.
pub fn run(a: RenderArgs) -> anyhow::Result<()> {
    let out = execute(&a, false)?;
    out.image.save_png(&a.output)?;
    println!("wrote {}", a.output.display());
    if let Some(path) = &a.stats {
        std::fs::write(path, serde_json::to_string_pretty(&out.stats)?)
            .with_context(|| format!("cannot write {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn print_cell_summary(a: &RenderArgs, input: &RenderInput, s: &cell::CellStats) {
    let sc = &input.scene.image;
    println!(
        "cell projection of {} ({}x{}, {} integrator, {} order, partial composition {}, {} threads)",
        a.scene.display(),
        sc.width,
        sc.height,
        s.integrator,
        s.cell_order,
        if s.partial_composition { "on" } else { "off" },
        s.threads
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
}
