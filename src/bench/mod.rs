//! `pvrsim bench`: times the renderers on the shared aorta scenes, one thread
//! and all threads, and prints a table (median of repeated renders, load
//! excluded). Needs `../shared/data` (or `--data-dir`); says so if absent.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

pub mod adaptive;
pub mod calibrate;
pub mod calibrate_grid;
pub mod calibrate_network;
pub mod calibrate_phase2;
pub mod calibrate_pieces;
pub mod calibrate_splat;
pub mod grid;
pub mod orderings;
pub mod scaling;
pub mod scaling_plot;
pub mod scaling_scenes;
pub mod splat;
pub mod splat_experiments;
pub mod timer;

use crate::job::{output, with_threads};
use crate::render::cell::{self, CellOptions, Integrator};
use crate::render::{reference, RenderInput};

/// Options of `pvrsim bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Folder holding aorta.vtk and the aorta-view-*.toml scenes.
    #[arg(long, default_value = "../shared/data")]
    pub data_dir: PathBuf,
    /// Scenes to time (file names in the data folder).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "aorta-view-a.toml,aorta-view-b.toml"
    )]
    pub scenes: Vec<String>,
    /// Renders per configuration; the median is reported.
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Also time the reference renderer (slow) once per scene.
    #[arg(long)]
    pub reference: bool,
    /// Write the measurements as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Instead: time the splatting visit orders (axis, dda, quicksort,
    /// radix) on 64^3..256^3 grids, the paper's Table 1 (no data needed).
    #[arg(long)]
    pub orderings: bool,
    /// Instead: wall ms per splatting frame of 256^3 grids at 512^2 (DDA,
    /// ordering included) at the paper's fill rates, for the paths of
    /// `--splat-paths`, with image errors.
    #[arg(long)]
    pub splat: bool,
    /// Paths for `--splat` (base full|exact|incr|tableP, then +ert, +ertT,
    /// +kK; errors are against the first).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "exact,incr,table32,incr+ert,table32+ert"
    )]
    pub splat_paths: Vec<String>,
    /// Target fill rates for `--splat` (the paper's Table 3).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0.0144,0.0423,0.123,0.257"
    )]
    pub splat_fills: Vec<f64>,
    /// Thread counts for `--splat`.
    #[arg(long, value_delimiter = ',', default_value = "2")]
    pub splat_threads: Vec<usize>,
    /// Grids for `--splat`: hydrogen, mni152.
    #[arg(long, value_delimiter = ',', default_value = "hydrogen,mni152")]
    pub splat_grids: Vec<String>,
    /// `--splat`: also the error against the f64 grid reference.
    #[arg(long)]
    pub splat_reference: bool,
    /// Time the grid renderers (slice3d, slice2d) instead, on the shared
    /// grid scenes (`--grid-scenes`), 256^2 and 512^2, 1 and all threads,
    /// beside the grid reference's error.
    #[arg(long)]
    pub grids: bool,
    /// Grid scenes for `--grids` (file names in the data folder).
    #[arg(long, value_delimiter = ',', default_value = grid::GRID_SCENES)]
    pub grid_scenes: Vec<String>,
    /// Print Table 2 of the LOD paper (slice memory with and without
    /// per-slice LOD for a 1024^3 volume; arithmetic only) and exit.
    #[arg(long)]
    pub lod_table: bool,
    /// Adaptive block sampling by block count (the paper's Table 3 shape):
    /// size ratio, build time, frame time and image error against
    /// full-resolution slice3d and the reference, per scene, for the
    /// scene's TF and the paper's (opacity = value).
    #[arg(long)]
    pub adaptive: bool,
    /// Scenes for `--adaptive` (file names in the data folder; `ml64` =
    /// a generated 64^3 Marschner-Lobb grid).
    #[arg(long, value_delimiter = ',', default_value = adaptive::ADAPTIVE_SCENES)]
    pub adaptive_scenes: Vec<String>,
    /// Blocks per axis for `--adaptive`.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32")]
    pub adaptive_blocks: Vec<u64>,
    /// Tolerance for `--adaptive` (fraction of the scalar range).
    #[arg(long, default_value_t = 0.05)]
    pub adaptive_tolerance: f64,
    /// Scaling benchmark instead: generate the demo vessel at each of
    /// `--scaling-cells` (cached in `--scaling-cache`), render it one
    /// thread, exact, ERT off at each `--scaling-sizes`, and write
    /// `scaling.csv` and log-log plots into `--scaling-out`.
    #[arg(long)]
    pub scaling: bool,
    /// Cell counts for `--scaling`.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "150000,500000,2000000,5000000,20000000"
    )]
    pub scaling_cells: Vec<u64>,
    /// `--scaling`: skip cell counts above this (raise it to include e.g.
    /// 100000000 in `--scaling-cells` where memory allows).
    #[arg(long, default_value_t = 20_000_000)]
    pub max_cells: u64,
    /// Square image sizes for `--scaling` (512 = 512x512).
    #[arg(long, value_delimiter = ',', default_value = "512,2048")]
    pub scaling_sizes: Vec<u32>,
    /// Render threads for `--scaling`.
    #[arg(long, default_value_t = 1)]
    pub scaling_threads: usize,
    /// Folder of generated meshes for `--scaling` (reused when present).
    #[arg(long, default_value = "scaling-cache")]
    pub scaling_cache: PathBuf,
    /// Folder for `--scaling`'s CSV, plots and per-point stats.
    #[arg(long, default_value = "scaling-out")]
    pub scaling_out: PathBuf,
    /// `--scaling` on these scene files (comma-separated) instead of the
    /// generated vessels (`--scaling-cells` is then not used): e.g. the
    /// gmsh parts and the permuted demo of `bench/meshes/make.sh`. Writes
    /// `scaling-scenes.csv` (ns a cell, ns a segment, B a tet) into
    /// `--scaling-out`.
    #[arg(long, value_delimiter = ',')]
    pub scaling_scenes: Vec<PathBuf>,
}

/// One timed configuration.
#[derive(Debug, serde::Serialize)]
pub struct BenchRow {
    /// Scene file name.
    pub scene: String,
    /// Renderer and integrator.
    pub renderer: String,
    /// Threads.
    pub threads: usize,
    /// Median render time without loading, ms.
    pub median_ms: f64,
    /// Fastest render, ms.
    pub min_ms: f64,
    /// Median scan-conversion time, ms.
    pub scan_ms: f64,
    /// Projected cells per second of total render time.
    pub cells_per_s: f64,
    /// Ray segments per second of total render time.
    pub segments_per_s: f64,
    /// Segments generated.
    pub segments: u64,
    /// Floor estimate: segments x the ns per segment of the memory-bound
    /// kernel of `render::cell::floor` on this machine, one thread, ms.
    pub floor_ms: f64,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Runs `pvrsim bench`.
pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    if a.orderings {
        return orderings::run(a.json.as_deref());
    }
    if !a.scaling && !a.scaling_scenes.is_empty() {
        anyhow::bail!("--scaling-scenes is an option of --scaling (add --scaling)");
    }
    if a.scaling && !a.scaling_scenes.is_empty() {
        let rows = scaling_scenes::run(
            &a.scaling_scenes,
            &a.scaling_sizes,
            a.scaling_threads,
            &a.scaling_out,
        )?;
        if let Some(path) = &a.json {
            std::fs::write(path, serde_json::to_string_pretty(&rows)?)?;
            println!("wrote {}", path.display());
        }
        return Ok(());
    }
    if a.scaling {
        let b = scaling::ScalingBench {
            cells: a.scaling_cells.clone(),
            max_cells: a.max_cells,
            sizes: a.scaling_sizes.clone(),
            threads: a.scaling_threads,
            cache: a.scaling_cache.clone(),
            out: a.scaling_out.clone(),
        };
        let rows = scaling::run(&b)?;
        if let Some(path) = &a.json {
            std::fs::write(path, serde_json::to_string_pretty(&rows)?)?;
            println!("wrote {}", path.display());
        }
        return Ok(());
    }
    if a.splat {
        let b = splat::SplatBench {
            repeats: a.repeats,
            paths: a.splat_paths.clone(),
            fills: a.splat_fills.clone(),
            threads: a.splat_threads.clone(),
            reference: a.splat_reference,
            grids: a.splat_grids.clone(),
        };
        return splat::run(&a.data_dir, &b, a.json.as_deref());
    }
    if a.lod_table {
        let rows = grid::lod_table();
        if let Some(path) = &a.json {
            std::fs::write(path, serde_json::to_string_pretty(&rows)?)?;
        }
        return Ok(());
    }
    if a.adaptive {
        let rows = adaptive::run(
            &a.data_dir,
            &a.adaptive_scenes,
            &a.adaptive_blocks,
            a.adaptive_tolerance,
        )?;
        if let Some(path) = &a.json {
            std::fs::write(path, serde_json::to_string_pretty(&rows)?)?;
            println!("wrote {}", path.display());
        }
        return Ok(());
    }
    if a.grids {
        let rows = grid::run(&a.data_dir, &a.grid_scenes, a.repeats)?;
        if let Some(path) = &a.json {
            std::fs::write(path, serde_json::to_string_pretty(&rows)?)?;
            println!("wrote {}", path.display());
        }
        return Ok(());
    }
    let rows = a.cell_rows(|e| match e {
        BenchEvent::Floor(ns) => {
            println!(
                "floor kernel (render::cell::floor, 1 thread): {ns:.2} ns/segment; \
                 floor ms = segments x that / threads"
            );
            print_header();
        }
        BenchEvent::Row(r) => print_row(r),
    })?;
    if let Some(path) = &a.json {
        std::fs::write(path, serde_json::to_string_pretty(&rows)?)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// A benchmark as a typed job: `pvrsim bench`'s options with its defaults.
pub type BenchJob = BenchArgs;

/// What [`BenchArgs::cell_rows`] reports while it measures.
pub enum BenchEvent<'a> {
    /// The floor kernel's ns per segment on this machine, measured first.
    Floor(f64),
    /// A configuration measured.
    Row(&'a BenchRow),
}

impl BenchArgs {
    /// `pvrsim bench`'s defaults, timing the scenes in `data_dir`.
    pub fn new(data_dir: impl Into<PathBuf>) -> Self {
        let cmd = <BenchArgs as Args>::augment_args(clap::Command::new("pvrsim bench"));
        let m = cmd
            .try_get_matches_from(["pvrsim bench"])
            .expect("the defaults parse");
        let mut job =
            <BenchArgs as clap::FromArgMatches>::from_arg_matches(&m).expect("the defaults parse");
        job.data_dir = data_dir.into();
        job
    }

    /// The cell-projection benchmark (the default mode): per scene, exact
    /// and midpoint integrators on one thread and on all cores, ERT off,
    /// median of `repeats` renders (load excluded), with the floor
    /// estimate; the reference once per scene with `reference`. `on_event`
    /// sees the floor and each row as they are measured (the command line
    /// prints them).
    pub fn cell_rows(&self, mut on_event: impl FnMut(BenchEvent)) -> anyhow::Result<Vec<BenchRow>> {
        let a = self;
        anyhow::ensure!(
            a.data_dir.join("aorta.vtk").exists(),
            "benchmark data not found: {} has no aorta.vtk. The benchmark needs the shared data \
             folder: --data-dir pointing at it (the default ../shared/data is relative to the \
             current folder, so run from the checkout that has ../shared beside it).",
            shown_dir(&a.data_dir)
        );
        let cores = std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1);
        let mut rows = Vec::new();
        let floor_ns = cell::floor::ns_per_segment();
        on_event(BenchEvent::Floor(floor_ns));
        for name in &a.scenes {
            let path = a.data_dir.join(name);
            let (input, _) = RenderInput::load(&path)
                .with_context(|| format!("cannot load {}", path.display()))?;
            for integrator in [Integrator::Exact, Integrator::Midpoint] {
                let mut thread_counts = vec![1];
                if cores > 1 {
                    thread_counts.push(cores);
                }
                for &threads in &thread_counts {
                    let opts = CellOptions {
                        integrator,
                        ert: cell::ErtOptions::OFF,
                        ..Default::default()
                    };
                    let mut total = Vec::new();
                    let mut scan = Vec::new();
                    let mut last = None;
                    for _ in 0..a.repeats.max(1) {
                        let (_, s) = with_threads(threads, || cell::render(&input, &opts))?;
                        total.push(s.time_total_s * 1e3);
                        scan.push(s.time_scan_s * 1e3);
                        last = Some(s);
                    }
                    let s = last.expect("at least one repeat");
                    let min_ms = total.iter().cloned().fold(f64::INFINITY, f64::min);
                    let med = median(&mut total);
                    let row = BenchRow {
                        scene: name.clone(),
                        renderer: format!("cell {integrator}"),
                        threads,
                        median_ms: med,
                        min_ms,
                        scan_ms: median(&mut scan),
                        cells_per_s: s.cells_projected as f64 / (med / 1e3),
                        segments_per_s: s.segments_generated as f64 / (med / 1e3),
                        segments: s.segments_generated,
                        floor_ms: s.segments_generated as f64 * floor_ns * 1e-6 / threads as f64,
                    };
                    on_event(BenchEvent::Row(&row));
                    rows.push(row);
                }
            }
            if a.reference {
                let adjacency = input.mesh.adjacency();
                let (_, rs) = with_threads(cores, || {
                    reference::render(&input, &adjacency, &Default::default())
                })?;
                let row = BenchRow {
                    scene: name.clone(),
                    renderer: "reference".into(),
                    threads: cores,
                    median_ms: rs.time_s * 1e3,
                    min_ms: rs.time_s * 1e3,
                    scan_ms: rs.time_s * 1e3,
                    cells_per_s: 0.0,
                    segments_per_s: 0.0,
                    segments: 0,
                    floor_ms: 0.0,
                };
                on_event(BenchEvent::Row(&row));
                rows.push(row);
            }
        }
        Ok(rows)
    }
}

fn print_header() {
    println!(
        "{:<20} {:<16} {:>7} {:>11} {:>9} {:>9} {:>11} {:>13} {:>9} {:>8}",
        "scene",
        "renderer",
        "threads",
        "median ms",
        "min ms",
        "scan ms",
        "Mcells/s",
        "Msegments/s",
        "floor ms",
        "x floor"
    );
}

fn print_row(r: &BenchRow) {
    println!(
        "{:<20} {:<16} {:>7} {:>11.1} {:>9.1} {:>9.1} {:>11.2} {:>13.2} {:>9.1} {:>8.2}",
        r.scene,
        r.renderer,
        r.threads,
        r.median_ms,
        r.min_ms,
        r.scan_ms,
        r.cells_per_s / 1e6,
        r.segments_per_s / 1e6,
        r.floor_ms,
        if r.floor_ms > 0.0 {
            r.median_ms / r.floor_ms
        } else {
            0.0
        }
    );
}

/// `dir` as given, and where it resolves from the current folder when it
/// is relative (`../shared/data (= /work/shared/data)`).
pub fn shown_dir(dir: &std::path::Path) -> String {
    match std::env::current_dir() {
        Ok(cwd) if dir.is_relative() => {
            format!("{} (= {})", dir.display(), cwd.join(dir).display())
        }
        _ => dir.display().to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bench_job_has_the_command_lines_defaults_and_names_missing_data() {
        let job = BenchJob::new("/nonexistent-pvrsim-data");
        assert_eq!(job.repeats, 5);
        assert_eq!(job.scenes, ["aorta-view-a.toml", "aorta-view-b.toml"]);
        assert!(!job.grids && !job.reference);
        let mut events = 0;
        let e = job.cell_rows(|_| events += 1).expect_err("no data there");
        assert!(
            e.to_string()
                .contains("/nonexistent-pvrsim-data has no aorta.vtk"),
            "{e}"
        );
        assert_eq!(events, 0, "nothing is measured before the data is found");
    }
}
