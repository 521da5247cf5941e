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

pub use super::report::series::{Coherence, SeriesFrame, SeriesReport};
use super::{phase1, place, run_placed, ClockKind, ClusterConfig, ClusterOutcome};
use crate::net::SimTrace;
use crate::node::{Placement, PlacementMethod};
use crate::render::RenderInput;
use crate::scene::Camera;

/// What one frame of a series renders: which of the series' data states
/// (mesh and field: one per time step), from which camera, with which
/// transfer function.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// Index into the series' inputs.
    pub data: usize,
    /// The camera.
    pub camera: Camera,
    /// The transfer function.
    pub transfer: crate::scene::TransferFunction,
}

impl Step {
    /// The frame's input: `inputs[self.data]` seen from this step's camera
    /// through its transfer function.
    pub fn input(&self, inputs: &[RenderInput]) -> RenderInput {
        let mut i = inputs[self.data].clone();
        i.scene.camera = self.camera;
        i.scene.transfer = self.transfer.clone();
        i
    }
}

/// Runs one frame per step on nodes that keep their cells across the
/// frames (in this process: the virtual clock, or threads): see
/// [`LocalFrames`]. `progress` is called after each frame with its index.
pub fn run(
    inputs: &[RenderInput],
    steps: &[Step],
    cfg: &ClusterConfig,
    coherence: Coherence,
    mut progress: impl FnMut(usize, &ClusterOutcome),
) -> anyhow::Result<Vec<ClusterOutcome>> {
    let mut nodes = LocalFrames::new(cfg.clone(), coherence);
    let mut outs = Vec::with_capacity(steps.len());
    for (f, step) in steps.iter().enumerate() {
        crate::base::cancel::checkpoint();
        let out = nodes.frame(inputs, step)?;
        progress(f, &out);
        outs.push(out);
    }
    Ok(outs)
}

/// Nodes in this process that keep their cells across frames: the
/// placement and the nodes' data are built once per data state (a time
/// step rebuilds them) and, with [`Coherence::Placement`], again when the
/// last frame moved cells.
pub struct LocalFrames {
    cfg: ClusterConfig,
    coherence: Coherence,
    kept: Option<(usize, Placement, phase1::NodeData)>,
}

impl LocalFrames {
    /// Nodes of `cfg`, nothing built yet.
    pub fn new(cfg: ClusterConfig, coherence: Coherence) -> LocalFrames {
        LocalFrames {
            cfg,
            coherence,
            kept: None,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &ClusterConfig {
        &self.cfg
    }

    /// One frame: `step` over `inputs` (its data state, camera and
    /// transfer function).
    pub fn frame(&mut self, inputs: &[RenderInput], step: &Step) -> anyhow::Result<ClusterOutcome> {
        let cfg = &self.cfg;
        let input = step.input(inputs);
        // A view-aligned placement follows the camera; the others, and the
        // nodes' data with them, are the same for every frame of a data state.
        if cfg.placement == PlacementMethod::RcbView {
            return super::run(&input, cfg);
        }
        if self.kept.as_ref().is_none_or(|k| k.0 != step.data) {
            let placement = place(&input, cfg);
            let data = phase1::NodeData::new(&input, &placement, &cfg.phase1)?;
            self.kept = Some((step.data, placement, data));
        }
        let (_, placement, data) = self.kept.as_ref().expect("built above");
        let out = run_placed(&input, cfg, placement, data)?;
        if self.coherence == Coherence::Placement && out.report.cells_moved > 0 {
            if let Some(next) = carried(placement, &out.processed) {
                let data = phase1::NodeData::new(&input, &next, &cfg.phase1)?;
                self.kept = Some((step.data, next, data));
            }
        }
        Ok(out)
    }
}

/// The placement a frame ended with: each cell on the node that processed
/// it, the others (culled) where `placement` put them. `None` when nothing
/// moved.
pub fn carried(placement: &Placement, processed: &[Vec<u32>]) -> Option<Placement> {
    if processed.len() != placement.parts.len() {
        return None;
    }
    let cells: usize = placement.parts.iter().map(Vec::len).sum();
    let mut owner = vec![0u32; cells];
    for (k, part) in placement.parts.iter().enumerate() {
        for &c in part {
            owner[c as usize] = k as u32;
        }
    }
    let mut moved = false;
    for (k, cells) in processed.iter().enumerate() {
        for &c in cells {
            if let Some(o) = owner.get_mut(c as usize) {
                moved |= *o != k as u32;
                *o = k as u32;
            }
        }
    }
    if !moved {
        return None;
    }
    let mut parts = vec![Vec::new(); placement.parts.len()];
    for (c, &k) in owner.iter().enumerate() {
        parts[k as usize].push(c as u32);
    }
    Some(Placement { parts })
}

/// What a real transport measured of one frame of a series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasuredFrame {
    /// Wall seconds, from its set-up to the image.
    pub frame_s: f64,
    /// Bytes on the wire (set-up and cells included).
    pub bytes: u64,
    /// Of them, the cells sent at set-up.
    pub cells_bytes: u64,
    /// The slowest worker's compress seconds.
    pub compress_s: Option<f64>,
}

/// The series section of `outs` (one outcome per step of `steps`).
/// `measured[i]`: what a real transport measured of frame i (`None`: the
/// report's own times and modelled bytes).
pub fn report(
    outs: &[ClusterOutcome],
    steps: &[Step],
    measured: Option<&[MeasuredFrame]>,
    coherence: Coherence,
) -> SeriesReport {
    let frames: Vec<SeriesFrame> = outs
        .iter()
        .zip(steps)
        .enumerate()
        .map(|(f, (o, c))| {
            let r = &o.report;
            let (frame_s, bytes, cells_bytes, compress_s) = match measured.and_then(|m| m.get(f)) {
                Some(m) => (m.frame_s, m.bytes, m.cells_bytes, m.compress_s),
                None => (r.frame_s, r.bytes_total, 0, None),
            };
            SeriesFrame {
                frame: f,
                data: c.data,
                eye: c.camera.eye,
                frame_s,
                phase1_s: r.phase1_s,
                composite_s: r.composite_s,
                compress_s,
                bytes,
                cells_bytes,
                cells_skipped_ert: r.cells_skipped_ert,
                cells_moved: r.cells_moved,
                reassigned: r
                    .transport
                    .as_ref()
                    .and_then(|t| t.reassigned.clone())
                    .or_else(|| r.pieces.as_ref().and_then(|p| p.reassigned.clone())),
            }
        })
        .collect();
    let total_s: f64 = frames.iter().map(|f| f.frame_s).sum();
    let rate = |n: usize, s: f64| if s > 0.0 { n as f64 / s } else { 0.0 };
    let later: f64 = frames.iter().skip(1).map(|f| f.frame_s).sum();
    SeriesReport {
        n_frames: frames.len(),
        coherence,
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
