//! What re-placing the cells for a new view costs (`--placement rcb-view`
//! with replicated data: every node computes the view-aligned placement of
//! the whole mesh itself, so no cell moves; the cost is the computation),
//! measured against building one cell's record on arrival (what
//! `per_cell_receive` prices). The ratio per cell is `PLACEMENT_COST_RATIO`
//! in `src/node/replica.rs`.
//!
//! ```text
//! cargo run --release --example placement_cost [-- scene.toml [nodes]]   # default: aorta-small view B, 8
//! ```
//!
//! Prints the median of 5 rounds of each.

use std::path::PathBuf;
use std::time::Instant;

use pvrsim::node::{NodeOptions, NodeRenderer, Placement, PlacementMethod, WorkUnit};
use pvrsim::render::cell::PreparedTf;
use pvrsim::render::RenderInput;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = args.next().map(PathBuf::from).unwrap_or_else(|| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/aorta-small-view-b.toml")
    });
    let n: usize = args.next().map_or(Ok(8), |s| s.parse())?;
    let (input, _) = RenderInput::load(&scene)?;
    let view = input.scene.view();
    let cells = input.mesh.tets.len();
    let all: Vec<u32> = (0..cells as u32).collect();
    let unit = WorkUnit::from_mesh(&input.mesh, &input.s_norm, &all);
    let (mut place, mut record) = (Vec::new(), Vec::new());
    for _ in 0..5 {
        let t = Instant::now();
        let p = Placement::new(&input.mesh, n, PlacementMethod::RcbView, Some(&view));
        place.push(t.elapsed().as_secs_f64() / cells as f64);
        std::hint::black_box(p);
        let mut r = NodeRenderer::new(
            view,
            PreparedTf::new(&input.scene.transfer),
            NodeOptions::default(),
        );
        let t = Instant::now();
        r.add_work(&unit)?;
        record.push(t.elapsed().as_secs_f64() / cells as f64);
    }
    let (p, r) = (median(place), median(record));
    println!(
        "{}: {cells} cells, {n} nodes; per cell: rcb-view placement {:.1} ns, record on arrival {:.1} ns, ratio {:.4}",
        scene.display(),
        p * 1e9,
        r * 1e9,
        p / r
    );
    Ok(())
}
