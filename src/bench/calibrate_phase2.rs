//! `pvrsim calibrate`, phase 2: the unit costs of compositing ray-segment
//! lists between nodes, measured directly (as sharing and work packing
//! are): each calibration scene split over 2 and 4 nodes (RCB), every node's
//! lists rendered, then a binary swap of them under the run-length codec
//! in this thread, the encoding of every round's messages
//! ([`LocalRun::outgoing`]) and their decoding and merging
//! ([`LocalRun::deliver`]) timed apart. Seconds per segment sent and per
//! segment received are the totals over the lists rounds divided by the
//! segments those rounds carried; each configuration keeps its fastest of
//! the repeats. The virtual clock charges them in
//! [`crate::cluster::phase2`].

use super::timer::{Timer, Watch};
use crate::compositor::{ExecOptions, LocalRun, Payload, RoundKind};
use crate::node::renderer::NodeErt;
use crate::node::{NodeOptions, NodeRenderer, Placement, PlacementMethod, WorkUnit};
use crate::render::cell::PreparedTf;
use crate::render::RenderInput;

/// Measured phase-2 unit costs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Phase2Costs {
    /// Seconds per segment encoded into a lists message.
    pub per_segment_sent: f64,
    /// Seconds per segment decoded and merged on arrival.
    pub per_segment_received: f64,
    /// Segments the timed rounds carried (per configuration, summed).
    pub segments: u64,
}

/// Encode and decode-and-merge seconds, and segments carried, of one
/// binary swap of `input` over `nodes` nodes.
fn one_swap(input: &RenderInput, nodes: usize, timer: Timer) -> anyhow::Result<(f64, f64, u64)> {
    let view = input.scene.view();
    let opts = NodeOptions {
        ert: NodeErt::OFF,
        ..Default::default()
    };
    let parts = Placement::new(&input.mesh, nodes, PlacementMethod::Rcb, Some(&view)).parts;
    let mut lists = Vec::with_capacity(nodes);
    for cells in &parts {
        let tf = PreparedTf::new(&input.scene.transfer);
        let mut node = NodeRenderer::new(view, tf, opts);
        node.add_work(&WorkUnit::from_mesh(&input.mesh, &input.s_norm, cells))
            .map_err(|e| anyhow::anyhow!("phase-2 calibration: {e}"))?;
        while node.remaining() > 0 {
            node.step(usize::MAX);
        }
        lists.push(crate::cluster::node_lists(&node, input, opts));
    }
    let strategy =
        crate::compositor::strategy::from_name("binary-swap").map_err(|e| anyhow::anyhow!(e))?;
    let codec = crate::compositor::codec::from_name("rle").map_err(|e| anyhow::anyhow!(e))?;
    let mut run = LocalRun::new(
        strategy.as_ref(),
        codec.as_ref(),
        lists,
        ExecOptions {
            partial: opts.partial_composition,
            ..Default::default()
        },
    )?;
    let (mut enc, mut dec, mut segs) = (0.0, 0.0, 0u64);
    while let Some(kind) = run.next_round().map(|r| r.kind) {
        let t = Watch::start(timer);
        let msgs = run.outgoing()?;
        let t_enc = t.secs();
        let carried: u64 = msgs
            .iter()
            .map(|m| match m.what {
                Payload::Lists(rect) => crate::compositor::codec::raw_lists_segments(
                    m.raw_bytes,
                    rect.width() as u64 * rect.height() as u64,
                ),
                Payload::Pixels(_) => 0,
            })
            .sum();
        let t = Watch::start(timer);
        run.deliver(msgs)?;
        if kind == RoundKind::Lists {
            enc += t_enc;
            dec += t.secs();
            segs += carried;
        }
    }
    Ok((enc, dec, segs))
}

/// Times binary swaps of every input on 2 and 4 nodes, `repeats` times
/// each (fastest kept).
pub fn measure(
    inputs: &[RenderInput],
    repeats: usize,
    timer: Timer,
) -> anyhow::Result<Phase2Costs> {
    let (mut enc, mut dec, mut segs) = (0.0, 0.0, 0u64);
    for (input, nodes) in inputs.iter().flat_map(|i| [(i, 2usize), (i, 4)]) {
        let mut best: Option<(f64, f64, u64)> = None;
        for _ in 0..repeats.max(1) {
            let r = one_swap(input, nodes, timer)?;
            best = Some(match best {
                None => r,
                Some(b) => (b.0.min(r.0), b.1.min(r.1), r.2),
            });
        }
        let (e, d, s) = best.expect("at least one run");
        enc += e;
        dec += d;
        segs += s;
    }
    anyhow::ensure!(
        segs > 0,
        "phase-2 calibration: the binary swaps carried no segment"
    );
    Ok(Phase2Costs {
        per_segment_sent: enc / segs as f64,
        per_segment_received: dec / segs as f64,
        segments: segs,
    })
}
