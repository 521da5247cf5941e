//! Times the stages of one single-threaded cell-projection frame (ERT off),
//! median of N runs, to show where the time goes outside the scan loop:
//!
//! ```text
//! cargo run --release --example phase_times -- ../shared/data/aorta-view-b.toml 9
//! ```

use std::time::Instant;

use pvrsim::render::cell::{self, bin, project, CellOptions, ErtOptions, PreparedTf};
use pvrsim::render::RenderInput;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .map(String::as_str)
        .unwrap_or("tests/data/aorta-small-view-b.toml");
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(7);
    let (input, _) = RenderInput::load(std::path::Path::new(path))?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let opts = CellOptions {
        ert: ErtOptions::OFF,
        ..Default::default()
    };
    let (mut tp, mut tb, mut tt) = (vec![], vec![], vec![]);
    pool.install(|| {
        for _ in 0..n {
            let view = input.scene.view();
            let tf = PreparedTf::new(&input.scene.transfer);
            let t0 = Instant::now();
            let pv = project::ProjectedVertices::new(&view, &input.mesh.points, &input.s_norm);
            let t1 = Instant::now();
            let b = bin::bin_cells_rect(
                &input.mesh.tets,
                &pv,
                &tf,
                32,
                32,
                cell::CellOrder::FrontToBack,
                cell::single::OnePixelMode::Hits,
            );
            let t2 = Instant::now();
            std::hint::black_box(&b);
            drop(b);
            let (_, s) = cell::render(&input, &opts);
            tp.push((t1 - t0).as_secs_f64() * 1e3);
            tb.push((t2 - t1).as_secs_f64() * 1e3);
            tt.push(s.time_total_s * 1e3);
        }
    });
    println!(
        "project vertices {:.1} ms, bin {:.1} ms, whole render {:.1} ms",
        median(tp),
        median(tb),
        median(tt)
    );
    Ok(())
}
