//! Diagnostic: how many cells could the 8 nodes skip if they processed their
//! cells in the global front-to-back order (no concurrency loss), with the
//! paper's per-entry merge or a per-pixel merge, exchanged at the sequential
//! update schedule with no delay?
//! `cargo run --release --example share_bound -- SCENE [N]`

use pvrsim::node::renderer::NodeErt;
use pvrsim::node::table::entry_px;
use pvrsim::node::{NodeOptions, NodeRenderer, Placement, PlacementMethod, SharedTable, WorkUnit};
use pvrsim::render::cell::PreparedTf;
use pvrsim::render::RenderInput;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = args
        .next()
        .unwrap_or("../shared/data/aorta-view-b.toml".into());
    let n = 8usize;
    let (input, _) = RenderInput::load(std::path::Path::new(&scene))?;
    let opts = NodeOptions {
        ert: NodeErt::PAPER,
        ..Default::default()
    };
    let view = input.scene.view();
    let tf = PreparedTf::new(&input.scene.transfer);
    let (w, h) = (view.width, view.height);
    let p = Placement::new(&input.mesh, n, PlacementMethod::Rcb, None);
    let modes: Vec<String> = args.map(|s| s.to_string()).collect();
    for mode in modes.iter().map(|s| s.as_str()) {
        let mut nodes: Vec<NodeRenderer> = p
            .parts
            .iter()
            .map(|part| {
                let mut r = NodeRenderer::new(view, tf.clone(), opts);
                r.add_work(&WorkUnit::from_mesh(&input.mesh, &input.s_norm, part))
                    .unwrap();
                r
            })
            .collect();
        let (nx, ny) = nodes[0].table_dims();
        let (ex, ey) = entry_px(w, h, opts.ert.divisions);
        let mut since = 0usize;
        let total = |nodes: &[NodeRenderer]| nodes.iter().map(|r| r.remaining()).sum::<usize>();
        let mut interval = (total(&nodes) / 100).max(1);
        while let Some(k) = (0..n)
            .filter_map(|k| nodes[k].next_order_key().map(|key| (key, k)))
            .min()
            .map(|x| x.1)
        {
            let r = nodes[k].step(1);
            if r.update_due {
                nodes[k].update_table();
            }
            since += 1;
            if since >= interval {
                since = 0;
                interval = (total(&nodes) / 100).max(1);
                for r in nodes.iter_mut() {
                    r.update_table();
                }
                let mut t = SharedTable::empty(nx as u16, ny as u16);
                if mode == "entry" {
                    for r in &nodes {
                        let l = r.local_table();
                        for (a, b) in t.deepest.iter_mut().zip(&l.deepest) {
                            *a = a.min(*b);
                        }
                    }
                } else if let Some(bl) = mode.strip_prefix("b") {
                    let (b, l) = bl.split_once('l').unwrap();
                    let b: u32 = b.parse().unwrap();
                    let l: usize = l.parse().unwrap();
                    let (bx, by) = (w.div_ceil(b), h.div_ceil(b));
                    let thr = opts.ert.threshold();
                    let a: Vec<f32> = (1..=l)
                        .map(|j| {
                            if j == l {
                                thr
                            } else {
                                1.0 - (1.0 - thr).powf(j as f32 / l as f32)
                            }
                        })
                        .collect();
                    // per node, per entry, per level: max over pixels of the depth reaching it
                    let ne = (bx * by) as usize;
                    let mut per: Vec<Vec<f32>> = Vec::new();
                    for r in &nodes {
                        let mut t = vec![f32::NEG_INFINITY; ne * l];
                        for y in 0..h {
                            for x in 0..w {
                                let e = ((y / b) * bx + x / b) as usize;
                                let list = r.list(x, y);
                                let mut acc = 0.0f32;
                                let mut j = 0;
                                for s in list {
                                    acc += (1.0 - acc) * s.rgba.a;
                                    while j < l && acc >= a[j] {
                                        let v = &mut t[e * l + j];
                                        *v = v.max(s.z_back);
                                        j += 1;
                                    }
                                    if j == l {
                                        break;
                                    }
                                }
                                for jj in j..l {
                                    t[e * l + jj] = f32::INFINITY;
                                }
                            }
                        }
                        per.push(t);
                    }
                    let mut blk = vec![f32::INFINITY; ne];
                    for e in 0..ne {
                        let mut cand: Vec<f32> = per
                            .iter()
                            .flat_map(|t| t[e * l..(e + 1) * l].iter().copied())
                            .filter(|d| d.is_finite())
                            .collect();
                        cand.sort_by(|a, b| a.partial_cmp(b).unwrap());
                        for z in cand {
                            let units: usize = per
                                .iter()
                                .map(|t| t[e * l..(e + 1) * l].iter().filter(|&&d| d <= z).count())
                                .sum();
                            if units >= l {
                                blk[e] = z;
                                break;
                            }
                        }
                    }
                    for e in 0..(nx * ny) {
                        let (x0, y0) = ((e % nx) * ex, (e / nx) * ey);
                        let mut m = f32::NEG_INFINITY;
                        for y in y0..(y0 + ey).min(h) {
                            for x in x0..(x0 + ex).min(w) {
                                m = m.max(blk[((y / b) * bx + x / b) as usize]);
                            }
                        }
                        t.deepest[e as usize] = m;
                    }
                } else {
                    let mut d = vec![f32::INFINITY; (w * h) as usize];
                    for r in &nodes {
                        for (a, b) in d.iter_mut().zip(r.termination_depths()) {
                            *a = a.min(*b);
                        }
                    }
                    for e in 0..(nx * ny) {
                        let (x0, y0) = ((e % nx) * ex, (e / nx) * ey);
                        let mut m = f32::NEG_INFINITY;
                        for y in y0..(y0 + ey).min(h) {
                            for x in x0..(x0 + ex).min(w) {
                                m = m.max(d[(y * w + x) as usize]);
                            }
                        }
                        t.deepest[e as usize] = m;
                    }
                }
                for r in nodes.iter_mut() {
                    r.apply_shared(&t).unwrap();
                }
            }
        }
        let skipped: u64 = nodes.iter().map(|r| r.totals().cells_skipped_ert).sum();
        println!("{mode}: skipped {skipped}");
    }
    let mut s = NodeRenderer::new(view, tf.clone(), opts);
    let all: Vec<u32> = (0..input.mesh.tets.len() as u32).collect();
    s.add_work(&WorkUnit::from_mesh(&input.mesh, &input.s_norm, &all))?;
    let o = s.run_to_end();
    println!("sequential: skipped {}", o.cells_skipped_ert);
    Ok(())
}
