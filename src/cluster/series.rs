//! A frame series of a mesh scene on nodes that persist across frames
//! (`pvrsim cluster --frames N --turn DEG`): the placement and every node's
//! cells with their vertex data are built once ([`phase1::NodeData`]), and
//! each frame changes only the camera. Each frame computes exactly what a
//! one-off frame at its camera computes (same placement, same cells per
//! node, same protocol), so its image is the one-off frame's bit for bit.
//!
//! The series' own numbers ([`SeriesReport`]: frames per second, per-frame
//! times, bytes, cells skipped and moved) are built from the frames'
//! reports by [`report`], whatever ran the frames (this
//! process, or worker processes).

pub use super::report::series::{SeriesFrame, SeriesReport};
use super::{phase1, place, run_placed, ClockKind, ClusterConfig, ClusterOutcome};
use crate::net::SimTrace;
use crate::node::PlacementMethod;
use crate::render::RenderInput;
use crate::scene::Camera;

/// Runs one frame per camera on nodes that keep their cells across the
/// frames (in this process: the virtual clock, or threads). `progress` is
/// called after each frame with its index.
pub fn run(
    input: &RenderInput,
    cfg: &ClusterConfig,
    cams: &[Camera],
    mut progress: impl FnMut(usize, &ClusterOutcome),
) -> anyhow::Result<Vec<ClusterOutcome>> {
    let mut input = input.clone();
    // A view-aligned placement follows the camera; the others, and the
    // nodes' data with them, are the same for every frame.
    let per_view = cfg.placement == PlacementMethod::RcbView;
    let mut kept = None;
    let mut outs = Vec::with_capacity(cams.len());
    for (f, cam) in cams.iter().enumerate() {
        crate::base::cancel::checkpoint();
        input.scene.camera = *cam;
        let out = if per_view {
            super::run(&input, cfg)?
        } else {
            if kept.is_none() {
                let placement = place(&input, cfg);
                let data = phase1::NodeData::new(&input, &placement, &cfg.phase1)?;
                kept = Some((placement, data));
            }
            let (placement, data) = kept.as_ref().expect("built above");
            run_placed(&input, cfg, placement, data)?
        };
        progress(f, &out);
        outs.push(out);
    }
    Ok(outs)
}

/// The series section of `outs` (one outcome per camera of `cams`).
/// `measured[i]`: frame i's measured wall seconds, wire bytes and
/// cell bytes on a real transport (`None`: the report's own times and
/// modelled bytes).
pub fn report(
    outs: &[ClusterOutcome],
    cams: &[Camera],
    measured: Option<&[(f64, u64, u64)]>,
) -> SeriesReport {
    let frames: Vec<SeriesFrame> = outs
        .iter()
        .zip(cams)
        .enumerate()
        .map(|(f, (o, c))| {
            let r = &o.report;
            let (frame_s, bytes, cells_bytes) = match measured.and_then(|m| m.get(f)) {
                Some(&(s, b, cb)) => (s, b, cb),
                None => (r.frame_s, r.bytes_total, 0),
            };
            SeriesFrame {
                frame: f,
                eye: c.eye,
                frame_s,
                phase1_s: r.phase1_s,
                composite_s: r.composite_s,
                bytes,
                cells_bytes,
                cells_skipped_ert: r.cells_skipped_ert,
                cells_moved: r.cells_moved,
            }
        })
        .collect();
    let total_s: f64 = frames.iter().map(|f| f.frame_s).sum();
    let rate = |n: usize, s: f64| if s > 0.0 { n as f64 / s } else { 0.0 };
    let later: f64 = frames.iter().skip(1).map(|f| f.frame_s).sum();
    SeriesReport {
        n_frames: frames.len(),
        clock: if measured.is_some() {
            ClockKind::Wall
        } else {
            outs.first()
                .map(|o| o.report.clock)
                .unwrap_or(ClockKind::Virtual)
        },
        fps: rate(frames.len(), total_s),
        fps_after_first: (frames.len() > 1).then(|| rate(frames.len() - 1, later)),
        total_s,
        frames,
    }
}


/// One timeline over the whole series: each frame's events shifted to
/// start where the previous frame ended.
pub fn joined_trace(outs: &[ClusterOutcome]) -> SimTrace {
    let mut trace = SimTrace::default();
    let mut t0 = 0.0;
    for o in outs {
        let mut end: f64 = 0.0;
        for e in &o.trace.events {
            let mut e = e.clone();
            end = end.max(e.end);
            e.start += t0;
            e.end += t0;
            trace.events.push(e);
        }
        t0 += end.max(o.report.frame_s);
    }
    trace
}
