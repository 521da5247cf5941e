//! `pvrsim bench --splat`: wall-clock ms per splatting frame of a 256^3
//! grid at 512^2 (issue 11's speed target), ordering included, DDA order,
//! at the paper's fill rates, on 1 and 2 threads, for four paths measured
//! in the same run:
//!
//! - `full`: the full DDA walk testing every voxel's threshold, projection
//!   on one thread, exact footprints (conic + two exponentials per pixel):
//!   the previous renderer;
//! - `prepass`: transparency pre-pass + sparse walk + parallel projection,
//!   exact footprints (same image as `full`, bit for bit: same order, same
//!   per-splat arithmetic; the error columns show it);
//! - `incr`: `prepass` with forward-differenced footprints (the default;
//!   differs from `full` by f32 rounding);
//! - `table`: `prepass` with the orthographic footprint table (8 x 8
//!   phases), whose image differs from `full` by the phase rounding.
//!
//! Grids: the generated hydrogen atom (KVS, `generate::hydrogen`) at 256^3,
//! always; the MNI152 template resampled to 256^3 when the shared data
//! folder has it (skipped with a message otherwise).

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use super::splat_experiments::{ramp_tf, resample, scene_for, threshold_for};
use crate::data::volume::generate::hydrogen;
use crate::data::Volume;
use crate::image::Image;
use crate::render::splat::order::Order;
use crate::render::splat::{render_splat, SplatOptions};
use crate::render::VolumeInput;

/// The paper's fill rates of its 256^3 skull (Table 3).
pub const FILLS: [f64; 4] = [0.0144, 0.0423, 0.123, 0.257];

/// One timed configuration.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SplatBenchRow {
    /// `hydrogen256` or `mni152-256`.
    pub grid: String,
    /// The paper's fill rate the threshold was chosen for.
    pub fill_target: f64,
    /// Measured fill rate (drawn / voxels).
    pub fill: f64,
    /// Footprints drawn.
    pub drawn: u64,
    /// Threads.
    pub threads: usize,
    /// `full`, `prepass`, `incr` or `table`.
    pub path: String,
    /// Median wall ms per frame (ordering included).
    pub wall_ms: f64,
    /// Ordering + pre-pass + projection of that frame, ms.
    pub order_ms: f64,
    /// Rasterising of that frame, ms.
    pub splat_ms: f64,
    /// Process CPU ms (all threads) of that frame, order + splat.
    pub cpu_ms: f64,
    /// Max-abs difference to the `full` path's image, 1/255.
    pub max_abs_vs_full: f64,
    /// RMSE against the `full` path's image, 1/255.
    pub rmse_vs_full: f64,
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

/// The four paths.
fn paths() -> [(&'static str, SplatOptions); 4] {
    let base = SplatOptions {
        order: Order::Dda,
        ..Default::default()
    };
    [
        (
            "full",
            SplatOptions {
                sparse: false,
                incremental: false,
                ..base
            },
        ),
        (
            "prepass",
            SplatOptions {
                incremental: false,
                ..base
            },
        ),
        ("incr", base),
        (
            "table",
            SplatOptions {
                table_phases: 8,
                ..base
            },
        ),
    ]
}

/// Times one grid; appends rows and prints them.
fn bench_grid(
    name: &str,
    vol: &Arc<Volume>,
    repeats: usize,
    rows: &mut Vec<SplatBenchRow>,
) -> anyhow::Result<()> {
    for &target in &FILLS {
        let t = threshold_for(vol, target) + 0.5 / 255.0;
        let scene = scene_for(vol, 30.0, 25.0, 512, ramp_tf(t, vol.spacing[0]));
        let input = VolumeInput::new(scene, vol.clone())?;
        let mut full_img: Option<Image> = None;
        let mut line = Vec::new();
        for threads in [1usize, 2] {
            for (path, opts) in paths() {
                let mut runs = Vec::new();
                let mut img = None;
                for _ in 0..repeats.max(1) {
                    let (i, st, ms) = super::with_threads(threads, || {
                        let t0 = Instant::now();
                        let (i, st) = render_splat(&input, &opts)?;
                        anyhow::Ok((i, st, t0.elapsed().as_secs_f64() * 1e3))
                    })??;
                    runs.push((ms, st));
                    img = Some(i);
                }
                runs.sort_by(|a, b| a.0.total_cmp(&b.0));
                let (wall_ms, st) = runs.swap_remove(runs.len() / 2);
                let img = img.expect("at least one frame");
                if full_img.is_none() {
                    full_img = Some(img.clone());
                }
                let e = img.error_against(full_img.as_ref().expect("set above"));
                let row = SplatBenchRow {
                    grid: name.into(),
                    fill_target: target,
                    fill: st.fill_rate,
                    drawn: st.voxels_drawn,
                    threads,
                    path: path.into(),
                    wall_ms,
                    order_ms: st.order_ms,
                    splat_ms: st.splat_ms,
                    cpu_ms: st.order_cpu_ms + st.splat_cpu_ms,
                    max_abs_vs_full: e.max_abs,
                    rmse_vs_full: e.rmse,
                };
                line.push(row.clone());
                rows.push(row);
            }
        }
        // One markdown row per thread count: full | prepass | incr | table.
        for th in [1usize, 2] {
            let r: Vec<&SplatBenchRow> = line.iter().filter(|r| r.threads == th).collect();
            let ms = |r: &SplatBenchRow| {
                format!(
                    "{:.0} ({:.0} + {:.0}) cpu {:.0}",
                    r.wall_ms, r.order_ms, r.splat_ms, r.cpu_ms
                )
            };
            println!(
                "| {name} | {:.4} | {} | {th} | {} | {} | {} | {} | {:.1} / {:.1} | {:.2} / {:.3} | {:.2} / {:.3} | {:.2} / {:.3} |",
                r[0].fill,
                r[0].drawn,
                ms(r[0]),
                ms(r[1]),
                ms(r[2]),
                ms(r[3]),
                r[0].wall_ms / r[2].wall_ms,
                r[0].cpu_ms / r[2].cpu_ms,
                r[1].max_abs_vs_full,
                r[1].rmse_vs_full,
                r[2].max_abs_vs_full,
                r[2].rmse_vs_full,
                r[3].max_abs_vs_full,
                r[3].rmse_vs_full,
            );
        }
    }
    Ok(())
}

/// Runs `pvrsim bench --splat`.
pub fn run(data_dir: &Path, repeats: usize, json: Option<&Path>) -> anyhow::Result<()> {
    println!(
        "splat frames, 256^3 grids at 512^2, DDA order, orthographic (azimuth 30, elevation 25), \
         median of {} wall-clock frames; load average at start: {}",
        repeats.max(1),
        load_average()
    );
    println!(
        "columns: wall ms (order + splat wall ms) and process CPU ms per path; full/incr = speed-up in wall / CPU; error vs full: max-abs / RMSE in 1/255\n"
    );
    println!("| grid | fill | drawn | threads | full ms | prepass ms | incr ms | table ms | full/incr | prepass err | incr err | table err |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    let h = Arc::new(hydrogen(256));
    bench_grid("hydrogen256", &h, repeats, &mut rows)?;
    drop(h);
    let mni = data_dir.join("mni152_t1.nhdr");
    if mni.exists() {
        let src = crate::data::io::read_volume(&mni, "")?;
        let vol = Arc::new(resample(&src, 256));
        bench_grid("mni152-256", &vol, repeats, &mut rows)?;
    } else {
        println!(
            "\nskipped mni152-256: {} is absent (give --data-dir)",
            mni.display()
        );
    }
    println!("\nload average at end: {}", load_average());
    if let Some(path) = json {
        std::fs::write(path, serde_json::to_string_pretty(&rows)?)
            .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
