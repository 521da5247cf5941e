//! `pvrsim bench --splat`: wall-clock ms per splatting frame of a 256^3
//! grid at 512^2 (issue 11's speed target), ordering included, DDA order,
//! at the paper's fill rates, for named paths measured in the same run
//! (`--splat-paths`, [`parse_path`]): a base
//!
//! - `full`: the full DDA walk testing every voxel's threshold, projection
//!   on one thread, exact footprints (the first renderer);
//! - `exact`: transparency pre-pass + sparse walk + parallel projection,
//!   exact footprints (conic + two exponentials per pixel);
//! - `incr`: `exact` with forward-differenced footprints;
//! - `tableP`: `exact` with the orthographic footprint table at `P x P`
//!   phases;
//!
//! then `+ert` (early splat elimination at 0.99; `+ertT` at threshold `T`)
//! and `+kK` (footprint cut at `K` standard deviations, default 3). Without
//! `+ert` a path composites back to front (ERT off). The default renderer
//! (orthographic) is `table32+ert`. Errors (max-abs / RMSE in 1/255) are against the first
//! path of the list, and with `--splat-reference` also against the f64
//! grid reference.
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
use crate::render::grid_reference;
use crate::render::splat::order::Order;
use crate::render::splat::{render_splat, SplatOptions};
use crate::render::VolumeInput;

/// One timed configuration.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SplatBenchRow {
    /// `hydrogen256` or `mni152-256`.
    pub grid: String,
    /// The paper's fill rate the threshold was chosen for.
    pub fill_target: f64,
    /// Measured fill rate (drawn / voxels).
    pub fill: f64,
    /// Footprints drawn (kept, on screen).
    pub drawn: u64,
    /// Threads.
    pub threads: usize,
    /// The path ([`parse_path`]).
    pub path: String,
    /// Median wall ms per frame (ordering included).
    pub wall_ms: f64,
    /// Ordering + pre-pass + projection of that frame, ms.
    pub order_ms: f64,
    /// Of `order_ms`: the transparency pre-pass (0 for `full`).
    pub prepass_ms: f64,
    /// Of `order_ms`: ordering with projection (0 for `full`).
    pub project_ms: f64,
    /// Rasterising of that frame, ms.
    pub splat_ms: f64,
    /// Of `splat_ms`: binning the splats by band.
    pub bin_ms: f64,
    /// Process CPU ms (all threads) of that frame, order + splat.
    pub cpu_ms: f64,
    /// (splat, band) pieces and the share skipped by early splat
    /// elimination.
    pub pieces: u64,
    /// Pieces skipped.
    pub pieces_skipped_ert: u64,
    /// The stated ERT bound, 1/255.
    pub ert_bound_255: f64,
    /// Max-abs difference to the first path's image, 1/255.
    pub max_abs_vs_first: f64,
    /// RMSE against the first path's image, 1/255.
    pub rmse_vs_first: f64,
    /// Max-abs / RMSE against the grid reference, 1/255 (with
    /// `--splat-reference`).
    pub vs_reference: Option<[f64; 2]>,
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

/// The options of a named path (module doc): `full`, `exact`, `incr` or
/// `tableP`, then optional `+ert`, `+ertT`, `+kK`.
pub fn parse_path(name: &str) -> anyhow::Result<SplatOptions> {
    let mut parts = name.split('+');
    let base = parts.next().unwrap_or_default();
    let mut o = SplatOptions {
        order: Order::Dda,
        ert: 1.0,
        table_phases: 0,
        ..Default::default()
    };
    match base {
        "full" => {
            o.sparse = false;
            o.incremental = false;
        }
        "exact" => o.incremental = false,
        "incr" => {}
        t if t.starts_with("table") => {
            let p: u32 = t[5..].parse().map_err(|_| {
                anyhow::anyhow!("--splat-paths {name}: `{t}` is not tableP (P = 1..=64)")
            })?;
            anyhow::ensure!(
                (1..=64).contains(&p),
                "--splat-paths {name}: table phases must be 1..=64"
            );
            o.table_phases = p;
        }
        other => anyhow::bail!(
            "--splat-paths {name}: unknown base `{other}` (full, exact, incr or tableP)"
        ),
    }
    for m in parts {
        if let Some(t) = m.strip_prefix("ert") {
            o.ert = if t.is_empty() {
                0.99
            } else {
                t.parse()
                    .map_err(|_| anyhow::anyhow!("--splat-paths {name}: `{m}` is not ertT"))?
            };
            crate::job::validate::ert_mode(o.ert)?;
        } else if let Some(k) = m.strip_prefix('k') {
            o.k_cut = k
                .parse()
                .map_err(|_| anyhow::anyhow!("--splat-paths {name}: `{m}` is not kK"))?;
            anyhow::ensure!(
                o.k_cut > 0.5 && o.k_cut <= 6.0,
                "--splat-paths {name}: the cut K must be in (0.5, 6]"
            );
        } else {
            anyhow::bail!("--splat-paths {name}: unknown modifier `{m}` (ert, ertT, kK)");
        }
    }
    Ok(o)
}

/// What to run.
#[derive(Debug, Clone)]
pub struct SplatBench {
    /// Frames per cell (median reported).
    pub repeats: usize,
    /// Named paths; the first is the error reference.
    pub paths: Vec<String>,
    /// Target fill rates.
    pub fills: Vec<f64>,
    /// Thread counts.
    pub threads: Vec<usize>,
    /// Also the grid reference's error (one f64 render per fill rate).
    pub reference: bool,
    /// Grids: `hydrogen`, `mni152`.
    pub grids: Vec<String>,
}

/// Times one grid; appends rows and prints them.
fn bench_grid(
    name: &str,
    vol: &Arc<Volume>,
    b: &SplatBench,
    paths: &[(String, SplatOptions)],
    rows: &mut Vec<SplatBenchRow>,
) -> anyhow::Result<()> {
    for &target in &b.fills {
        let t = threshold_for(vol, target) + 0.5 / 255.0;
        let scene = scene_for(vol, 30.0, 25.0, 512, ramp_tf(t, vol.spacing[0]));
        let input = VolumeInput::new(scene, vol.clone())?;
        let reference = if b.reference {
            let (r, _) =
                super::with_threads(0, || grid_reference::render(&input, &Default::default()))?;
            Some(r)
        } else {
            None
        };
        let mut first: Option<Image> = None;
        for &threads in &b.threads {
            for (path, opts) in paths {
                let mut runs = Vec::new();
                let mut img = None;
                for _ in 0..b.repeats.max(1) {
                    let (i, st, ms) = super::with_threads(threads, || {
                        let t0 = Instant::now();
                        let (i, st) = render_splat(&input, opts)?;
                        anyhow::Ok((i, st, t0.elapsed().as_secs_f64() * 1e3))
                    })??;
                    runs.push((ms, st));
                    img = Some(i);
                }
                runs.sort_by(|a, b| a.0.total_cmp(&b.0));
                let (wall_ms, st) = runs.swap_remove(runs.len() / 2);
                let img = img.expect("at least one frame");
                if first.is_none() {
                    first = Some(img.clone());
                }
                let e = img.error_against(first.as_ref().expect("set above"));
                let r = reference.as_ref().map(|r| {
                    let e = img.error_against(r);
                    [e.max_abs, e.rmse]
                });
                let row = SplatBenchRow {
                    grid: name.into(),
                    fill_target: target,
                    fill: st.fill_rate,
                    drawn: st.voxels_drawn,
                    threads,
                    path: path.clone(),
                    wall_ms,
                    order_ms: st.order_ms,
                    prepass_ms: st.prepass_ms,
                    project_ms: st.project_ms,
                    splat_ms: st.splat_ms,
                    bin_ms: st.bin_ms,
                    cpu_ms: st.order_cpu_ms + st.splat_cpu_ms,
                    pieces: st.pieces,
                    pieces_skipped_ert: st.pieces_skipped_ert,
                    ert_bound_255: st.ert_error_bound * 255.0,
                    max_abs_vs_first: e.max_abs,
                    rmse_vs_first: e.rmse,
                    vs_reference: r,
                };
                println!(
                    "| {name} | {:.4} | {} | {threads} | {path} | {:.0} | {:.0} + {:.0} | {:.0} + {:.0} | {:.0} | {:.1} % | {:.2} | {:.2} / {:.3} | {} |",
                    row.fill,
                    row.drawn,
                    row.wall_ms,
                    row.prepass_ms,
                    row.project_ms,
                    row.bin_ms,
                    row.splat_ms - row.bin_ms,
                    row.cpu_ms,
                    100.0 * row.pieces_skipped_ert as f64 / row.pieces.max(1) as f64,
                    row.ert_bound_255,
                    row.max_abs_vs_first,
                    row.rmse_vs_first,
                    r.map_or("-".into(), |[m, s]| format!("{m:.2} / {s:.3}")),
                );
                rows.push(row);
            }
        }
    }
    Ok(())
}

/// Runs `pvrsim bench --splat`.
pub fn run(data_dir: &Path, b: &SplatBench, json: Option<&Path>) -> anyhow::Result<()> {
    let paths = b
        .paths
        .iter()
        .map(|p| Ok((p.clone(), parse_path(p)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    anyhow::ensure!(!paths.is_empty(), "--splat-paths is empty");
    anyhow::ensure!(!b.fills.is_empty(), "--splat-fills is empty");
    for &f in &b.fills {
        anyhow::ensure!(f > 0.0 && f < 1.0, "--splat-fills: {f} is not in (0, 1)");
    }
    for &t in &b.threads {
        anyhow::ensure!(t >= 1, "--splat-threads: thread counts must be >= 1");
    }
    for g in &b.grids {
        anyhow::ensure!(
            g == "hydrogen" || g == "mni152",
            "--splat-grids: unknown grid `{g}` (hydrogen, mni152)"
        );
    }
    println!(
        "splat frames, 256^3 grids at 512^2, DDA order, orthographic (azimuth 30, elevation 25), \
         median of {} wall-clock frames; load average at start: {}",
        b.repeats.max(1),
        load_average()
    );
    println!(
        "columns: wall ms; pre-pass and order+projection wall ms; binning + rasteriser wall ms; process CPU ms; \
         (splat, band) pieces skipped by ERT; the ERT bound; error vs the first path and vs the grid \
         reference (max-abs / RMSE in 1/255)\n"
    );
    println!("| grid | fill | drawn | threads | path | wall ms | pre-pass + order&project ms | bin + raster ms | CPU ms | ERT skipped | ERT bound | vs {} | vs reference |", paths[0].0);
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    if b.grids.iter().any(|g| g == "hydrogen") {
        let h = Arc::new(hydrogen(256));
        bench_grid("hydrogen256", &h, b, &paths, &mut rows)?;
    }
    if b.grids.iter().any(|g| g == "mni152") {
        let mni = data_dir.join("mni152_t1.nhdr");
        if mni.exists() {
            let src = crate::data::io::read_volume(&mni, "")?;
            let vol = Arc::new(resample(&src, 256));
            bench_grid("mni152-256", &vol, b, &paths, &mut rows)?;
        } else {
            println!(
                "\nskipped mni152-256: {} is absent (give --data-dir)",
                mni.display()
            );
        }
    }
    println!("\nload average at end: {}", load_average());
    if let Some(path) = json {
        std::fs::write(path, serde_json::to_string_pretty(&rows)?)
            .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_names_parse_and_bad_ones_are_refused() {
        let o = parse_path("incr+ert").unwrap();
        assert!(o.incremental && o.sparse && o.ert == 0.99 && o.table_phases == 0);
        assert_eq!(parse_path("table32+ert").unwrap(), SplatOptions::default());
        let o = parse_path("table16+ert0.9+k2.5").unwrap();
        assert_eq!((o.table_phases, o.ert, o.k_cut), (16, 0.9, 2.5));
        let o = parse_path("full").unwrap();
        assert!(!o.sparse && !o.incremental && o.ert == 1.0);
        for bad in [
            "",
            "fast",
            "table",
            "table0",
            "incr+ert2",
            "incr+k9",
            "incr+zz",
        ] {
            assert!(parse_path(bad).is_err(), "{bad}");
        }
    }
}
