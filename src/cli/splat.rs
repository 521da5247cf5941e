//! `pvrsim splat SCENE -o out.png --order axis|dda|quicksort|radix`: EWA
//! splatting of a grid scene (issue 11) with the splatter's own knobs, which
//! `pvrsim render --renderer splat` does not take (`--sigma`,
//! `--table-phases`, `--exact-footprints`, `--full-walk`, and `--profile`:
//! the modelled one-thread frame time beside the measured CPU time), with
//! `--compare` against the grid reference and `--stats` JSON. The everyday
//! path is `pvrsim render SCENE --renderer splat`, wired through the job
//! layer (`job/render/splat.rs`); this command calls the renderer directly.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context;
use clap::{Args, ValueEnum};

use crate::data::io::read_volume;
use crate::image::Image;
use crate::render::grid_reference;
use crate::render::splat::order::Order;
use crate::render::splat::{render_splat, SplatOptions};
use crate::render::VolumeInput;
use crate::scene::Scene;

/// The visit order, as named on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OrderArg {
    /// Westover's axis-aligned slices.
    Axis,
    /// The paper's DDA view-aligned order.
    Dda,
    /// Full depth sort (comparison sort).
    Sort,
    /// Full depth sort by quicksort (same as `sort`).
    Quicksort,
    /// Full depth sort by radix (counting) sort.
    Radix,
}

impl OrderArg {
    /// The renderer's order.
    pub fn order(self) -> Order {
        match self {
            OrderArg::Axis => Order::Axis,
            OrderArg::Dda => Order::Dda,
            OrderArg::Sort | OrderArg::Quicksort => Order::Quicksort,
            OrderArg::Radix => Order::Radix,
        }
    }
}

/// Options of `pvrsim splat`.
#[derive(Debug, Args)]
#[command(mut_arg("ert", |a| a.help(crate::job::args::shared::SPLAT_ERT_HELP)))]
pub struct SplatArgs {
    /// Scene file (TOML) whose data is a regular grid (.nhdr/.nrrd).
    pub scene: PathBuf,
    /// Output PNG.
    #[arg(short, long, default_value = "splat.png")]
    pub output: PathBuf,
    /// Voxel visit order.
    #[arg(long, value_enum, default_value_t = OrderArg::Dda)]
    pub order: OrderArg,
    /// Reconstruction kernel standard deviation, in voxels.
    #[arg(long, default_value_t = 0.6)]
    pub sigma: f64,
    /// Image width (overrides the scene; give --height too).
    #[arg(long, requires = "height")]
    pub width: Option<u32>,
    /// Image height (overrides the scene; give --width too).
    #[arg(long, requires = "width")]
    pub height: Option<u32>,
    /// Also render the grid reference; print max-abs/RMSE and write
    /// OUTPUT-compare.png (splat | reference | 8x difference).
    #[arg(long)]
    pub compare: bool,
    /// Write the statistics as JSON here.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Sub-pixel phases of the orthographic footprint table, 0..=64 (default
    /// 32, or 0 with --exact-footprints; 0: per-row forward differences;
    /// perspective views never use the table).
    #[arg(long)]
    pub table_phases: Option<u32>,
    /// The conic and an exponential per pixel instead of the footprint table
    /// (orthographic) or the forward-differenced footprints (perspective,
    /// or --table-phases 0).
    #[arg(long)]
    pub exact_footprints: bool,
    /// The full walk (every voxel's threshold tested, projection on one
    /// thread) instead of the transparency pre-pass and sparse walk.
    #[arg(long)]
    pub full_walk: bool,
    /// Early termination threshold (declared once: [`crate::job::args::shared::ErtArg`];
    /// the help this command shows is `SPLAT_ERT_HELP`).
    #[command(flatten)]
    pub ert: crate::job::args::shared::ErtArg,
    /// Also print the modelled one-thread frame time under this cost
    /// profile (`calibrated`, `pentium4`, `radeon9700` or a TOML file; its
    /// `per_splat_voxel`, `per_splat`, `per_splat_piece`, fitted by `pvrsim
    /// calibrate`) beside the measured CPU time of the frame.
    #[arg(long)]
    pub profile: Option<String>,
}

/// Loads a grid scene into a [`VolumeInput`].
pub fn load_input(scene_path: &std::path::Path) -> anyhow::Result<VolumeInput> {
    let scene = Scene::load(scene_path)?;
    let vol = read_volume(&scene.data.path, &scene.data.field)
        .with_context(|| format!("cannot load the volume of scene {}", scene_path.display()))?;
    Ok(VolumeInput::new(scene, Arc::new(vol))?)
}

/// Runs `pvrsim splat`.
pub fn run(a: SplatArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        a.sigma > 0.0 && a.sigma.is_finite(),
        "--sigma must be > 0, got {}",
        a.sigma
    );
    crate::budget::threads("--threads", a.threads)?;
    crate::budget::footprint("--sigma", a.sigma, 1.0, 1)?;
    {
        use crate::job::output::{prepare_output, OutputKind};
        prepare_output("-o", &a.output, OutputKind::Png)?;
        if let Some(p) = &a.stats {
            prepare_output("--stats", p, OutputKind::Json)?;
        }
    }
    let mut input = load_input(&a.scene)?;
    if let (Some(w), Some(h)) = (a.width, a.height) {
        anyhow::ensure!(w > 0 && h > 0, "--width and --height must be > 0");
        input = input.with_size(w, h);
    }
    crate::budget::image(
        "--width/--height or image.width/height",
        input.scene.image.width.into(),
        input.scene.image.height.into(),
    )?;
    super::validate::ert_mode(a.ert.threshold)?;
    anyhow::ensure!(
        !(a.exact_footprints && a.table_phases.is_some_and(|p| p > 0)),
        "--exact-footprints and --table-phases {} exclude each other (the table overrides \
         the per-pixel kernel)",
        a.table_phases.unwrap_or_default()
    );
    let table_phases = a
        .table_phases
        .unwrap_or(if a.exact_footprints { 0 } else { 32 });
    let opts = SplatOptions {
        ert: a.ert.threshold,
        order: a.order.order(),
        sigma: a.sigma,
        sparse: !a.full_walk,
        table_phases,
        incremental: !a.exact_footprints,
        ..Default::default()
    };
    anyhow::ensure!(
        table_phases <= 64,
        "--table-phases must be 0..=64, got {}",
        table_phases
    );
    let (img, st) = super::with_threads(a.threads, || render_splat(&input, &opts))??;
    img.save_png(&a.output)?;
    println!(
        "{}: order {}, {} of {} voxels drawn (fill rate {:.4}), order {:.1} ms, splat {:.1} ms, \
         ERT {}: {} of {} (splat, band) pieces skipped, bound {:.2}/255",
        a.output.display(),
        st.order,
        st.voxels_drawn,
        st.voxels_total,
        st.fill_rate,
        st.order_ms,
        st.splat_ms,
        // The option is an f32: print it as given (0.99, not 0.9900000095…).
        st.ert_threshold as f32,
        st.pieces_skipped_ert,
        st.pieces,
        st.ert_error_bound * 255.0
    );
    let mut json = serde_json::to_value(&st)?;
    if let Some(name) = &a.profile {
        let (p, shown) = crate::job::cluster::load_profile(name)?;
        let modelled = p.splat_time(&st) * 1e3;
        let cpu = st.order_cpu_ms + st.splat_cpu_ms;
        println!(
            "modelled {modelled:.1} ms with profile {shown}, measured {cpu:.1} ms CPU ({:.1} ms wall){}",
            st.order_ms + st.splat_ms,
            if modelled > 0.0 {
                format!(", ratio {:.2}", modelled / cpu)
            } else {
                " (the profile has no splat costs: run pvrsim calibrate)".to_string()
            }
        );
        json["modelled_ms"] = serde_json::to_value(modelled)?;
        json["profile"] = serde_json::to_value(shown)?;
    }
    if a.compare {
        let (r, _) = super::with_threads(a.threads, || {
            grid_reference::render(&input, &Default::default())
        })?;
        let e = img.error_against(&r);
        println!("vs grid reference: {e}");
        json["error_vs_reference"] = serde_json::to_value(e)?;
        let diff = Image::difference(&img, &r, 8.0);
        let out = a.output.with_file_name(format!(
            "{}-compare.png",
            a.output
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("splat")
        ));
        Image::side_by_side(&[&img, &r, &diff], 4).save_png(&out)?;
    }
    if let Some(p) = &a.stats {
        std::fs::write(p, serde_json::to_string_pretty(&json)?)
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    Ok(())
}
