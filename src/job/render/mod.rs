//! `pvrsim render`'s options ([`RenderArgs`]; validated in [`crate::job::rules`]) and what a
//! render produces ([`RenderOutcome`]). The work is in [`crate::job::run`]
//! (load, dispatch), [`crate::job::render::mesh`] and [`crate::job::render::grid`].

pub mod grid;
pub mod loaded;
pub mod mesh;
pub mod splat;

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use crate::render::cell::{CellOrder, ErtSpan, ErtStructure, Integrator};

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
    /// Regular grids, orthographic views: Lacroute's shear-warp over
    /// run-length encoded slices (bilinear within a slice, a 2D warp).
    #[value(name = "shearwarp")]
    ShearWarp,
}

/// What validating [`RenderArgs`] decided once
/// ([`crate::job::Valid::parsed`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderChoices {
    /// `--ert`: on with its threshold, or off.
    pub ert: crate::render::cell::ert::ErtMode,
}

/// Options of `pvrsim render`.
#[derive(Debug, Clone, Args)]
#[command(mut_arg("ert", |a| a.help(crate::job::args::shared::RENDER_ERT_HELP)))]
pub struct RenderArgs {
    /// Scene file (TOML, see the scene contract).
    pub scene: PathBuf,
    /// Output PNG.
    #[arg(short, long, default_value = "out.png")]
    pub output: PathBuf,
    /// Renderer. Default: picked from the data and the view: `cell` for a
    /// tetrahedral mesh; for a regular grid `shearwarp` when the camera is
    /// orthographic and pixels are at least as large as voxels (fastest),
    /// `slice3d` when it is perspective, the view magnifies the voxels, or
    /// a slicer option (--slices, --spacing, --classify, --order) is given.
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
    pub order: Option<crate::job::grid_order::GridOrder>,
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
    /// Early termination threshold (declared once: [`crate::job::args::shared::ErtArg`];
    /// the help this command shows is `RENDER_ERT_HELP`).
    #[command(flatten)]
    pub ert: crate::job::args::shared::ErtArg,
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
    /// What `pvrsim render` prints about the frame, a line each (the
    /// renderer, its times and counts, `--compare`'s verdict).
    pub summary: Vec<String>,
}

/// The path of the `--compare` strip: `OUTPUT-compare.png`.
pub fn compare_path(output: &std::path::Path) -> PathBuf {
    output.with_file_name(format!(
        "{}-compare.png",
        output.file_stem().unwrap_or_default().to_string_lossy()
    ))
}

impl RenderArgs {
    /// The integrator's name as `--integrator` spells it.
    pub fn integrator_name(&self) -> String {
        self.integrator
            .to_possible_value()
            .map(|v| v.get_name().to_string())
            .unwrap_or_default()
    }
}
