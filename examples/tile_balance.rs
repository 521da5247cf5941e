//! Prints how a frame's scan-conversion work is spread over its tiles (ERT
//! off, one thread): per tile the segments generated and the measured scan
//! time, the heaviest tile's share, and the best possible speed-up on N
//! threads if tiles are the unit of work (`total / max(tile, total / N)`):
//!
//! ```text
//! cargo run --release --example tile_balance -- ../shared/data/aorta-view-b.toml 32
//! ```

use std::time::Instant;

use pvrsim::render::cell::{self, CellOptions, ErtOptions};
use pvrsim::render::RenderInput;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .map(String::as_str)
        .unwrap_or("tests/data/aorta-small-view-b.toml");
    let tile: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(32);
    let (input, _) = RenderInput::load(std::path::Path::new(path))?;
    let opts = CellOptions {
        ert: ErtOptions::OFF,
        tile_size: tile,
        ..Default::default()
    };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let t = Instant::now();
    let frame = pool.install(|| cell::scan_frame(&input, &opts));
    let wall = t.elapsed().as_secs_f64();
    let segs: Vec<u64> = frame
        .tiles
        .iter()
        .map(|t| t.counts.segments_generated)
        .collect();
    let total: u64 = segs.iter().sum();
    let max = *segs.iter().max().unwrap_or(&0);
    let busy = segs.iter().filter(|&&s| s > 0).count();
    println!(
        "{path}: tile {tile}, {} tiles ({busy} with segments), {total} segments; heaviest tile {max} ({:.1} %)",
        segs.len(),
        100.0 * max as f64 / total.max(1) as f64
    );
    for n in [2u64, 4, 8] {
        let bound = total as f64 / (max as f64).max(total as f64 / n as f64);
        println!("  best speed-up on {n} threads with tiles as the unit: {bound:.2}x");
    }
    println!("  frame (project + scan), one thread: {:.1} ms", wall * 1e3);

    // Measured: each tile scanned alone (one thread), then the makespan of
    // the renderer's schedule (heaviest bin first, greedy) on N threads.
    let view = input.scene.view();
    let tf = cell::PreparedTf::new(&input.scene.transfer);
    let pv = cell::project::ProjectedVertices::new(&view, &input.mesh.points, &input.s_norm);
    let binning = cell::bin::bin_cells_rect(
        &input.mesh.tets,
        &pv,
        &tf,
        tile,
        tile,
        cell::CellOrder::FrontToBack,
        cell::single::OnePixelMode::Hits,
    );
    let mut cells = Vec::new();
    let mut times = vec![0.0f64; binning.tiles.len()];
    for _ in 0..3 {
        for (t, best) in times.iter_mut().enumerate() {
            let t0 = Instant::now();
            std::hint::black_box(cell::scan_bin(&binning, t, &pv, &tf, &opts, &mut cells));
            let dt = t0.elapsed().as_secs_f64();
            *best = if *best == 0.0 { dt } else { best.min(dt) };
        }
    }
    let total_t: f64 = times.iter().sum();
    let mut queue: Vec<usize> = (0..times.len()).collect();
    queue.sort_by_key(|&t| std::cmp::Reverse(binning.bins[t].len() + binning.segs(t).len()));
    for n in [2usize, 4, 8] {
        let mut load = vec![0.0f64; n];
        for &t in &queue {
            let k = (0..n)
                .min_by(|&a, &b| load[a].total_cmp(&load[b]))
                .unwrap_or(0);
            load[k] += times[t];
        }
        let makespan = load.iter().cloned().fold(0.0, f64::max);
        println!(
            "  measured tile times: {:.1} ms in all; schedule on {n} threads: makespan {:.1} ms = {:.2}x",
            total_t * 1e3,
            makespan * 1e3,
            total_t / makespan
        );
    }
    Ok(())
}
