//! What `--placement rcb-view` costs in a multi-view run with replicated
//! data: when the view turns by `d` degrees (about the camera's up axis,
//! through the mesh's bounding-box centre), the view-aligned placement is
//! recomputed and the cells whose node changes move as ids.
//!
//! Per view change, under the `pentium4` profile and the `gbe` network:
//!
//! - **placement**: every centroid projected and the recursive median
//!   splits, `PLACE_RATIO × per_cell_receive` per cell (the measured ratio
//!   of `cargo run --release --example placement_cost`: 639 ns vs 1316 ns
//!   for a record, 0.49), once on one host (the manager) — or each node
//!   computes it for itself, the same time in parallel (no message);
//! - **moves**: per moved cell the donor writes its id and the receiver
//!   reads it (`cell_id_cost`) and builds its record (`per_cell_receive`);
//!   spread over the receivers (the slowest receiver's share is printed);
//! - **network**: the id lists, about 2 bytes per moved cell (varint deltas),
//!   at the network's bandwidth.
//!
//! ```text
//! cargo run --release --example rcb_view_replace -- ../shared/data/aorta-view-b.toml 8
//! ```

use std::path::PathBuf;

use pvrsim::net::NetworkModel;
use pvrsim::node::{CostProfile, IdUnit, Placement, PlacementMethod};
use pvrsim::render::RenderInput;
use pvrsim::scene::View;

/// Measured: rcb-view placement per cell / record per cell (examples/placement_cost.rs).
const PLACE_RATIO: f64 = 0.49;

fn rotate(v: [f64; 3], axis: [f64; 3], a: f64) -> [f64; 3] {
    // Rodrigues: v cos a + (k x v) sin a + k (k . v)(1 - cos a).
    let (c, s) = (a.cos(), a.sin());
    let kv = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2];
    let x = [
        axis[1] * v[2] - axis[2] * v[1],
        axis[2] * v[0] - axis[0] * v[2],
        axis[0] * v[1] - axis[1] * v[0],
    ];
    [0, 1, 2].map(|i| v[i] * c + x[i] * s + axis[i] * kv * (1.0 - c))
}

fn turned(v: &View, centre: [f64; 3], deg: f64) -> View {
    let a = deg.to_radians();
    let rel = [0, 1, 2].map(|i| v.eye[i] - centre[i]);
    let r = rotate(rel, v.up, a);
    View {
        eye: [0, 1, 2].map(|i| centre[i] + r[i]),
        right: rotate(v.right, v.up, a),
        forward: rotate(v.forward, v.up, a),
        ..*v
    }
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = PathBuf::from(
        args.next()
            .expect("usage: rcb_view_replace scene.toml [nodes]"),
    );
    let n: usize = args.next().map_or(Ok(8), |s| s.parse())?;
    let (input, _) = RenderInput::load(&scene)?;
    let p = CostProfile::named("pentium4")?;
    let net = NetworkModel::from_name("gbe")?;
    let view = input.scene.view();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for q in &input.mesh.points {
        for i in 0..3 {
            lo[i] = lo[i].min(q[i]);
            hi[i] = hi[i].max(q[i]);
        }
    }
    let centre = [0, 1, 2].map(|i| 0.5 * (lo[i] + hi[i]));
    let cells = input.mesh.tets.len();
    let owner = |pl: &Placement| {
        let mut o = vec![0u32; cells];
        for (k, part) in pl.parts.iter().enumerate() {
            for &c in part {
                o[c as usize] = k as u32;
            }
        }
        o
    };
    let p0 = Placement::new(&input.mesh, n, PlacementMethod::RcbView, Some(&view));
    let o0 = owner(&p0);
    let place_s = PLACE_RATIO * p.per_cell_receive * cells as f64;
    println!(
        "{}: {cells} cells, {n} nodes; placement per view change {place_s:.2} s (pentium4, one host or every node in parallel)",
        scene.display()
    );
    println!("turn_deg moved moved_share max_to_one_node move_s_slowest id_bytes net_s total_s");
    for deg in [1.0, 2.0, 5.0, 10.0, 30.0, 90.0] {
        let v = turned(&view, centre, deg);
        let o1 = owner(&Placement::new(
            &input.mesh,
            n,
            PlacementMethod::RcbView,
            Some(&v),
        ));
        let mut to = vec![Vec::new(); n];
        for c in 0..cells {
            if o0[c] != o1[c] {
                to[o1[c] as usize].push(c as u32);
            }
        }
        let moved: usize = to.iter().map(|t| t.len()).sum();
        let max_to = to.iter().map(|t| t.len()).max().unwrap_or(0);
        let bytes: u64 = to
            .into_iter()
            .map(|t| IdUnit::new(t).encode().len() as u64)
            .sum();
        let move_s = max_to as f64 * (2.0 * p.cell_id_cost() + p.per_cell_receive);
        let net_s = net.wire_time(bytes);
        println!(
            "{deg} {moved} {:.3} {max_to} {move_s:.3} {bytes} {net_s:.4} {:.2}",
            moved as f64 / cells as f64,
            place_s + move_s + net_s
        );
    }
    Ok(())
}
