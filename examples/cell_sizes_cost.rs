//! Cost of the projected-cell-size statistics (`cell_pixels_*`,
//! `cell_extent_*`), which `render` computes after the timed phases:
//!
//!     cargo run --release --example cell_sizes_cost [SCENE]
//!
//! SCENE defaults to ../shared/data/aorta-view-b.toml.
use std::time::Instant;

use pvrsim::render::cell::{scan_frame, sizes::cell_sizes, CellOptions};
use pvrsim::render::RenderInput;

fn main() {
    let scene = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "../shared/data/aorta-view-b.toml".into());
    let (input, _) = RenderInput::load(std::path::Path::new(&scene))
        .unwrap_or_else(|e| panic!("cannot load {scene}: {e}"));
    let opts = CellOptions {
        tile_size: 900,
        ..Default::default()
    };
    let frame = scan_frame(&input, &opts);
    let mut best = f64::MAX;
    for _ in 0..20 {
        let t = Instant::now();
        std::hint::black_box(cell_sizes(&frame.binning));
        best = best.min(t.elapsed().as_secs_f64());
    }
    println!(
        "{scene}: cell_sizes {:.2} ms (min of 20); scan phase of the same frame {:.1} ms",
        best * 1e3,
        frame.time_scan_s * 1e3
    );
}
