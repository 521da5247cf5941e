//! `pvrsim bench --grids`: times `slice3d`, `slice2d` and `shearwarp`
//! (where the view allows it: orthographic) on the shared grid scenes at 256^2 and 512^2, one thread and all threads (median of
//! repeated frames; the frame-independent preparation, min–max blocks and
//! the tiled texture, is timed apart, once), `slice3d-linear` (slice3d
//! sampling the volume's own x-fastest layout, to show what the tiles
//! save), beside the grid reference's error at the same size;
//! samples per second per core and the fractions of the samples skipped
//! by empty space and by ERT. `pvrsim bench --lod-table` prints the LOD
//! paper's Table 2 (arithmetic only).

use std::path::Path;

use crate::image::Image;
use crate::render::shearwarp::{self, ShearWarpOptions};
use crate::render::slice2d::{self, lod, Slice2dOptions};
use crate::render::slice3d::{self, Layout, Slice3dOptions};
use crate::render::slicing::{Classify, SliceStats};
use crate::render::{grid_reference, VolumeInput};

/// One timed grid configuration.
#[derive(Debug, serde::Serialize)]
pub struct GridBenchRow {
    /// Scene file name.
    pub scene: String,
    /// Renderer.
    pub renderer: String,
    /// Image edge in pixels.
    pub size: u32,
    /// Threads.
    pub threads: usize,
    /// Median frame time, ms (preparation excluded).
    pub median_ms: f64,
    /// Fastest frame, ms.
    pub min_ms: f64,
    /// Process CPU time per frame over the repeats (all threads; Linux
    /// `/proc/self/stat`, 10 ms ticks; `None` elsewhere), ms. On a loaded
    /// machine the wall time overstates the cost; this does not.
    pub cpu_ms: Option<f64>,
    /// Preparation (min–max blocks; slice2d: the slice stack), ms.
    pub prepare_ms: f64,
    /// Samples taken per second per thread, millions.
    pub msamples_per_s_per_core: f64,
    /// Share of the in-volume samples skipped as empty space.
    pub skipped_empty: f64,
    /// Samples taken per pixel whose ray met the volume (the frame cost
    /// that follows what is visible).
    pub samples_per_pixel: f64,
    /// Classifying the min–max blocks for the TF (slice3d: with the leap
    /// distances), ms: what a TF change costs besides the frame.
    pub classify_ms: f64,
    /// Share skipped by ERT.
    pub skipped_ert: f64,
    /// Max-abs error against the grid reference, 1/255.
    pub max_abs: f64,
    /// RMSE against the grid reference, 1/255.
    pub rmse: f64,
}

/// CPU seconds (user + system) of this process so far, from
/// `/proc/self/stat` (fields 14 and 15, in ticks of 1/100 s).
fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &s[s.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: u64 = f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?;
    Some(ticks as f64 / 100.0)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// The grid scenes `bench --grids` uses by default.
pub const GRID_SCENES: &str = "mni152-view.toml,colin27-brain-view.toml,frog-view.toml";

/// Runs the grid benchmark over `scenes` in `data_dir`.
pub fn run(
    data_dir: &Path,
    scenes: &[String],
    repeats: usize,
) -> anyhow::Result<Vec<GridBenchRow>> {
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let mut rows = Vec::new();
    println!(
        "{:<24} {:<14} {:>5} {:>3} {:>9} {:>8} {:>8} {:>8} {:>10} {:>7} {:>7} {:>7} {:>7} {:>8} {:>7}",
        "scene",
        "renderer",
        "size",
        "thr",
        "median ms",
        "min ms",
        "cpu ms",
        "prep ms",
        "Msmp/s/cpu",
        "empty%",
        "ERT%",
        "smp/px",
        "cls ms",
        "max/255",
        "RMSE"
    );
    for name in scenes {
        let path = data_dir.join(name);
        anyhow::ensure!(
            path.exists(),
            "grid benchmark scene not found: {} (the benchmark needs the shared data folder: \
             --data-dir pointing at it; the default ../shared/data is relative to the current \
             folder)",
            super::shown_dir(&path)
        );
        let scene = crate::scene::Scene::load(&path)?;
        let vol = match crate::data::io::read_volume(&scene.data.path, &scene.data.field) {
            Ok(v) => v,
            Err(e) => {
                println!("SKIPPED {name}: cannot load its volume: {e}");
                continue;
            }
        };
        let base = VolumeInput::new(scene, std::sync::Arc::new(vol))?;
        for size in [256u32, 512] {
            let input = base.clone().with_size(size, size);
            let (reference, rs) = super::with_threads(cores, || {
                grid_reference::render(&input, &Default::default())
            })?;
            println!(
                "{:<24} {:<14} {:>5} {:>3} {:>9.1}   (reference, once)",
                name,
                "ref",
                size,
                cores,
                rs.time_s * 1e3
            );
            let prep = slice3d::prepare(&input, Classify::Post);
            // The same slicer on the volume's own x-fastest layout: what
            // the tiled texture saves, measured in the same run.
            let prep_linear = slice3d::prepare_with(&input, Classify::Post, Layout::Linear);
            // Shear-warp (the default for orthographic views that do not
            // magnify) when the view allows it.
            let sw_opts = ShearWarpOptions::default();
            let prep_sw = shearwarp::check(&input, &sw_opts)
                .is_ok()
                .then(|| shearwarp::prepare(&input));
            let mut renderers = vec!["slice3d", "slice3d-linear", "slice2d"];
            if prep_sw.is_some() {
                renderers.push("shearwarp");
            }
            let mut threads = vec![1];
            if cores > 1 {
                threads.push(cores);
            }
            for &t in &threads {
                for &renderer in &renderers {
                    let mut times = Vec::new();
                    let mut last: Option<(Image, SliceStats)> = None;
                    let cpu0 = cpu_seconds();
                    for _ in 0..repeats.max(1) {
                        let out = super::with_threads(t, || {
                            if renderer == "slice3d" {
                                slice3d::render_prepared(&input, &prep, &Slice3dOptions::default())
                            } else if renderer == "slice3d-linear" {
                                let o = Slice3dOptions::default();
                                slice3d::render_prepared(&input, &prep_linear, &o)
                            } else if let (Some(p), "shearwarp") = (&prep_sw, renderer) {
                                shearwarp::render_prepared(&input, p, &sw_opts)
                            } else {
                                slice2d::render(&input, &Slice2dOptions::default())
                            }
                        })??;
                        times.push(out.1.time_render_s * 1e3);
                        last = Some(out);
                    }
                    let cpu_ms = match (cpu0, cpu_seconds()) {
                        (Some(a), Some(b)) => Some((b - a) * 1e3 / repeats.max(1) as f64),
                        _ => None,
                    };
                    let (img, st) = last.expect("at least one repeat");
                    let min_ms = times.iter().cloned().fold(f64::INFINITY, f64::min);
                    let med = median(&mut times);
                    let e = img.error_against(&reference);
                    let all = (st.samples_taken + st.samples_skipped_empty + st.samples_skipped_ert)
                        .max(1) as f64;
                    let row = GridBenchRow {
                        scene: name.clone(),
                        renderer: renderer.into(),
                        size,
                        threads: t,
                        median_ms: med,
                        min_ms,
                        cpu_ms,
                        prepare_ms: if renderer == "slice3d" {
                            prep.time_s * 1e3
                        } else if renderer == "slice3d-linear" {
                            prep_linear.time_s * 1e3
                        } else if let (Some(p), "shearwarp") = (&prep_sw, renderer) {
                            p.time_s * 1e3
                        } else {
                            st.time_prepare_s * 1e3
                        },
                        // Per core: samples over the CPU time when known
                        // (robust to load), else over wall time x threads.
                        msamples_per_s_per_core: match cpu_ms {
                            Some(c) if c > 0.0 => st.samples_taken as f64 / (c / 1e3) / 1e6,
                            _ => st.samples_taken as f64 / (med / 1e3) / t as f64 / 1e6,
                        },
                        skipped_empty: st.samples_skipped_empty as f64 / all,
                        skipped_ert: st.samples_skipped_ert as f64 / all,
                        samples_per_pixel: st.samples_taken as f64
                            / st.pixels_covered.max(1) as f64,
                        classify_ms: st.time_classify_s * 1e3,
                        max_abs: e.max_abs,
                        rmse: e.rmse,
                    };
                    println!(
                        "{:<24} {:<14} {:>5} {:>3} {:>9.1} {:>8.1} {:>8.1} {:>8.1} {:>10.1} {:>7.1} {:>7.1} {:>7.1} {:>7.2} {:>8.2} {:>7.3}",
                        row.scene,
                        row.renderer,
                        row.size,
                        row.threads,
                        row.median_ms,
                        row.min_ms,
                        row.cpu_ms.unwrap_or(f64::NAN),
                        row.prepare_ms,
                        row.msamples_per_s_per_core,
                        100.0 * row.skipped_empty,
                        100.0 * row.skipped_ert,
                        row.samples_per_pixel,
                        row.classify_ms,
                        row.max_abs,
                        row.rmse
                    );
                    rows.push(row);
                }
            }
        }
    }
    Ok(rows)
}

/// Prints Table 2 of `slice-lod-memory.txt`: a 1024^3 volume over
/// (-1,-1,-1)..(1,1,1), 1024 slices of 4 B texels, D = 0.5 .. 1.5.
pub fn lod_table() -> Vec<lod::TableRow> {
    let rows = lod::table2(1024, 4, &[0.5, 0.75, 1.0, 1.25, 1.5]);
    println!("Table 2 (slice-lod-memory): 1024^3 voxels over (-1,-1,-1)..(1,1,1), 1024 slices, 4 B/voxel;");
    println!("slice x at d_x = D + 2x/1024, R_x = 1024 / 2^floor(log2(d_x / D))");
    println!(
        "{:>6} {:>14} {:>14} {:>10}",
        "D", "U1 (LOD) MB", "U2 (none) MB", "sigma %"
    );
    for r in &rows {
        println!(
            "{:>6} {:>14} {:>14} {:>10.3}",
            r.d,
            fmt_thousands(r.u1_mib),
            fmt_thousands(r.u2_mib),
            r.sigma_percent
        );
    }
    println!(
        "(MB = 2^20 bytes. U2 is one stack; a 2D slicer that switches axes keeps three: {} MB.)",
        fmt_thousands(3 * rows[0].u2_mib)
    );
    rows
}

fn fmt_thousands(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}
