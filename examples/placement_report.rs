//! Prints the initial placement's world boxes and screen footprints for a
//! scene: `cargo run --release --example placement_report -- SCENE [N] [rcb|morton]`.

use pvrsim::node::{Placement, PlacementMethod};
use pvrsim::render::RenderInput;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = args
        .next()
        .unwrap_or("../shared/data/aorta-view-b.toml".into());
    let n: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(8);
    let method = match args.next().as_deref() {
        Some("morton") => PlacementMethod::Morton,
        _ => PlacementMethod::Rcb,
    };
    let (input, _) = RenderInput::load(std::path::Path::new(&scene))?;
    let p = Placement::new(&input.mesh, n, method, Some(&input.scene.view()));
    for (k, w) in p.world(&input.mesh).iter().enumerate() {
        println!(
            "node {k}: {} cells, box [{:.1}, {:.1}, {:.1}] .. [{:.1}, {:.1}, {:.1}]",
            w.cells, w.min[0], w.min[1], w.min[2], w.max[0], w.max[1], w.max[2]
        );
    }
    let f = p.footprints(&input);
    for (k, node) in f.nodes.iter().enumerate() {
        println!(
            "node {k}: screen box {:?}, {} px covered",
            node.bbox, node.covered
        );
    }
    println!(
        "sum {} px, union {} px, overlap (sum / union) {:.2}",
        f.sum_covered, f.union_covered, f.overlap
    );
    for row in &f.pairwise {
        println!("{row:?}");
    }
    Ok(())
}
