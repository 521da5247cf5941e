//! Where the cluster's ERT loses skips against the sequential pyramid:
//! per node of the initial placement, its cells split into *exposed* (some
//! pixel of the range has no other node's cell in front of the cell's near
//! depth) and *behind* (every pixel has), with the cells the sequential
//! pyramid skips in each class.
//!
//! ```text
//! cargo run --release --example ert_gap -- scene.toml [nodes]
//! ```

use std::path::PathBuf;

use pvrsim::base::Rect;
use pvrsim::node::renderer::NodeErt;
use pvrsim::node::{NodeOptions, NodeRenderer, Placement, PlacementMethod, WorkUnit};
use pvrsim::render::cell::bin::cell_record;
use pvrsim::render::cell::ert::{ErtSpan, ErtStructure};
use pvrsim::render::cell::project::ProjectedVertices;
use pvrsim::render::cell::PreparedTf;
use pvrsim::render::RenderInput;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = PathBuf::from(args.next().expect("scene"));
    let n: usize = args.next().map_or(Ok(8), |s| s.parse())?;
    let (input, _) = RenderInput::load(&scene)?;
    let view = input.scene.view();
    let tf = PreparedTf::new(&input.scene.transfer);
    let (w, h) = (view.width, view.height);
    let cells = input.mesh.tets.len();
    let all: Vec<u32> = (0..cells as u32).collect();
    let opts = NodeOptions {
        ert: NodeErt {
            mode: pvrsim::render::cell::ert::ErtMode::On(0.9),
            span: ErtSpan::Single,
            structure: ErtStructure::Pyramid,
            share_levels: 4,
            ..NodeErt::PAPER
        },
        ..Default::default()
    };
    // Sequential: which cells are skipped.
    let mut seq = NodeRenderer::new(view, tf.clone(), opts);
    seq.add_work(&WorkUnit::from_mesh(&input.mesh, &input.s_norm, &all))?;
    let mut skipped = vec![false; cells];
    while seq.remaining() > 0 {
        let id = seq.unprocessed_cells().next().unwrap();
        let r = seq.step(1);
        skipped[id as usize] = r.ops.cells_skipped_ert > 0;
        if r.update_due {
            seq.update_table();
        }
    }
    println!(
        "sequential skipped {}",
        skipped.iter().filter(|&&s| s).count()
    );
    // Records of every cell.
    let s: Vec<f64> = input.s_norm.clone();
    let pv = ProjectedVertices::new_sequential(&view, &input.mesh.points, &s);
    let full = Rect {
        x0: 0,
        y0: 0,
        x1: w,
        y1: h,
    };
    let rec: Vec<_> = (0..cells)
        .map(|c| cell_record(c as u32, input.mesh.tets[c], &pv, &tf, full).ok())
        .collect();
    let p = Placement::new(&input.mesh, n, PlacementMethod::Rcb, Some(&view));
    let npx = (w * h) as usize;
    // F[k][p]: nearest near depth of node k's cells covering p.
    let mut f = vec![vec![f32::INFINITY; npx]; n];
    for (k, part) in p.parts.iter().enumerate() {
        for &c in part {
            if let Some(r) = &rec[c as usize] {
                for y in r.range[2]..=r.range[3] {
                    for x in r.range[0]..=r.range[1] {
                        let q = (y * w + x) as usize;
                        f[k][q] = f[k][q].min(r.near);
                    }
                }
            }
        }
    }
    println!("node cells exposed exposed_seqskip behind behind_seqskip");
    for (k, part) in p.parts.iter().enumerate() {
        let (mut e, mut es, mut b, mut bs) = (0, 0, 0, 0);
        for &c in part {
            let Some(r) = &rec[c as usize] else { continue };
            let mut behind = true;
            'o: for y in r.range[2]..=r.range[3] {
                for x in r.range[0]..=r.range[1] {
                    let q = (y * w + x) as usize;
                    let g = (0..n)
                        .filter(|&j| j != k)
                        .map(|j| f[j][q])
                        .fold(f32::INFINITY, f32::min);
                    if g >= r.near {
                        behind = false;
                        break 'o;
                    }
                }
            }
            let sk = skipped[c as usize] as u32;
            if behind {
                b += 1;
                bs += sk;
            } else {
                e += 1;
                es += sk;
            }
        }
        println!("{k} {} {e} {es} {b} {bs}", part.len());
    }
    Ok(())
}
