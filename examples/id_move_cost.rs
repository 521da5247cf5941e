//! Measures what moving one cell costs with replicated data (its id packed,
//! encoded, decoded: `IdUnit`) against partitioned data (the cell with its
//! vertices: `give_work` + `WorkUnit::encode` + `WorkUnit::decode`, exactly
//! what `pvrsim calibrate` times for `per_work_cell`). The ratio is
//! `ID_COST_RATIO` in `src/node/replica.rs`, used for `per_cell_id` by the
//! profiles that do not measure it.
//!
//! ```text
//! cargo run --release --example id_move_cost [-- scene.toml]   # default: tests/data/aorta-small-view-b.toml
//! ```
//!
//! Prints the median of 7 rounds of each (interleaved, same node state).

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use pvrsim::node::renderer::Given;
use pvrsim::node::replica::{IdUnit, Replica};
use pvrsim::node::{NodeOptions, NodeRenderer, WorkUnit};
use pvrsim::render::cell::PreparedTf;
use pvrsim::render::RenderInput;

fn node(input: &RenderInput, replicated: bool) -> NodeRenderer {
    let mut r = NodeRenderer::new(
        input.scene.view(),
        PreparedTf::new(&input.scene.transfer),
        NodeOptions::default(),
    );
    if replicated {
        r.set_replica(Arc::new(Replica::new(input.mesh.clone(), &input.s_norm)));
    }
    let all: Vec<u32> = (0..input.mesh.tets.len() as u32).collect();
    r.add_work(&WorkUnit::from_mesh(&input.mesh, &input.s_norm, &all))
        .expect("valid unit");
    r
}

/// Seconds per cell moved, giving thirds until 30 cells are left.
fn per_cell(input: &RenderInput, replicated: bool) -> f64 {
    let mut n = node(input, replicated);
    let cells = input.mesh.tets.len();
    let mut moved = 0usize;
    let t = Instant::now();
    while n.remaining() > 30 {
        let g = n.give(1.0 / 3.0, false);
        let b = g.encode();
        moved += match g {
            Given::Ids(_) => IdUnit::decode(&b, cells).expect("round trip").len(),
            Given::Cells(_) => WorkUnit::decode(&b).expect("round trip").len(),
        };
    }
    t.elapsed().as_secs_f64() / moved.max(1) as f64
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> anyhow::Result<()> {
    let scene = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/aorta-small-view-b.toml")
        });
    let (input, _) = RenderInput::load(&scene)?;
    let (mut cells, mut ids) = (Vec::new(), Vec::new());
    for _ in 0..7 {
        cells.push(per_cell(&input, false));
        ids.push(per_cell(&input, true));
    }
    let (c, i) = (median(cells), median(ids));
    println!(
        "{}: {} cells; per moved cell: work unit {:.1} ns, id {:.1} ns, ratio {:.4}",
        scene.display(),
        input.mesh.tets.len(),
        c * 1e9,
        i * 1e9,
        i / c
    );
    Ok(())
}
