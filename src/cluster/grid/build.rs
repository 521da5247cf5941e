//! The report of a grid frame: phase 2's rounds replayed on the modelled
//! network, per-rank numbers, totals ([`report`]).

use super::prepared::{Phase1Out, Prepared};
use super::{GridConfig, GridNodeReport, GridOutcome, GridReport};
use std::collections::BTreeMap;

use crate::cluster::phase1::ClockKind;
use crate::cluster::phase2::{replay, RoundPlan};
use crate::compositor::layer::exec as layer_exec;
use crate::image::Image;
use crate::net::MessageKind;
use crate::node::grid::device::blend_time;
use crate::render::VolumeInput;

/// The outcome of a frame whose phase 2 ran (in-process, or worker to
/// worker with `rounds` from the ranks' logs) since `t2`: the rounds
/// replayed on the modelled network, the report.
pub fn report(
    input: &VolumeInput,
    cfg: &GridConfig,
    prep: &Prepared,
    p1: Phase1Out,
    image: Image,
    rounds: Vec<layer_exec::LayerRound>,
    t2: std::time::Instant,
) -> anyhow::Result<GridOutcome> {
    let s = &input.scene;
    let total = prep.total;
    let ends = p1.ends;
    let render_s = ends.iter().fold(0.0f64, |a, &b| a.max(b));
    let mut plans: Vec<Vec<RoundPlan>> = vec![vec![RoundPlan::default(); rounds.len()]; total];
    let mut costs: Vec<BTreeMap<(u32, u32), f64>> = vec![BTreeMap::new(); total];
    let mut bytes_sent = vec![0u64; total];
    let (mut bytes, mut raw) = (0u64, 0u64);
    let mut round_rows = Vec::new();
    for (r, lr) in rounds.iter().enumerate() {
        if lr.composite {
            for (k, &px) in lr.blended.iter().enumerate() {
                plans[k][r].before += blend_time(px, &cfg.profile);
            }
        }
        // Early merges (radix-k) happen once the round's pieces are in:
        // charged before the next round's sends.
        for (k, &px) in lr.merged.iter().enumerate() {
            if px > 0 && r + 1 < rounds.len() {
                plans[k][r + 1].before += blend_time(px, &cfg.profile);
            }
        }
        let (mut rb, mut rr) = (0, 0);
        for m in &lr.messages {
            plans[m.from][r]
                .sends
                .push((m.to, m.bytes as usize, MessageKind::Image));
            plans[m.to][r].expect += 1;
            // Received subimages are blended in the composite round, except
            // the final gather's pieces, which are pasted (one blend).
            if !lr.composite && lr.label == "gather" {
                costs[m.to].insert(
                    (r as u32, m.from as u32),
                    blend_time(m.pixels, &cfg.profile),
                );
            }
            bytes_sent[m.from] += m.bytes;
            rb += m.bytes;
            rr += m.raw_bytes;
        }
        bytes += rb;
        raw += rr;
        round_rows.push((lr.label.clone(), lr.messages.len(), rb, rr));
    }
    let sim = replay(
        plans,
        costs,
        &cfg.network,
        cfg.record_trace && cfg.clock == ClockKind::Virtual,
    )?;
    let host2 = t2.elapsed().as_secs_f64();
    let composite_s = match cfg.clock {
        ClockKind::Virtual => sim.end_time,
        ClockKind::Wall => host2,
    };
    let mut trace = p1.trace;
    for mut e in sim.trace.events.iter().cloned() {
        e.start += render_s;
        e.end += render_s;
        trace.events.push(e);
    }
    let mut by_kind = BTreeMap::new();
    if bytes > 0 {
        by_kind.insert("image".to_string(), bytes);
    }
    let textures_cached = p1.stats.iter().map(|s| s.textures_cached).sum();
    let report = GridReport {
        image: [s.image.width, s.image.height],
        volume_dims: input.volume.dims,
        subvolumes: cfg.subvolumes,
        n_nodes: cfg.nodes,
        master: cfg.master,
        clock: cfg.clock,
        network: cfg.network_name.clone(),
        profile: cfg.profile_name.clone(),
        placement: cfg.placement,
        compositor: prep.strategy.label(),
        codec: prep.codec.name().to_string(),
        frame_s: render_s + composite_s,
        fps: 1.0 / (render_s + composite_s),
        render_s,
        composite_s,
        bytes_total: bytes,
        bytes_by_kind: by_kind,
        codec_ratio: if raw > 0 {
            bytes as f64 / raw as f64
        } else {
            1.0
        },
        rounds: round_rows,
        renderer: cfg.renderer,
        size_ratio: {
            let (t, o) = p1.stats.iter().fold((0u64, 0u64), |a, s| {
                (a.0 + s.texture_bytes, a.1 + s.original_bytes)
            });
            if o > 0 {
                t as f64 / o as f64
            } else {
                1.0
            }
        },
        prepare_s: p1.stats.iter().map(|s| s.prepare_s).fold(0.0, f64::max),
        oversized_bricks: p1.stats.iter().map(|s| s.device.oversized_bricks).sum(),
        nodes: p1
            .stats
            .into_iter()
            .zip(&ends)
            .zip(&bytes_sent)
            .map(|((st, &end), &b)| GridNodeReport {
                stats: st,
                render_end_s: end,
                bytes_sent: b,
            })
            .collect(),
        host_s: [p1.host_s, host2],
        wall_s: p1.host_s + host2,
        textures_cached,
        transport: None,
    };
    Ok(GridOutcome {
        image,
        report,
        trace,
    })
}
