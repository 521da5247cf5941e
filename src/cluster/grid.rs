//! The cluster with grid nodes (sort-last rendering of regular grids,
//! `parallel-texture-vr-rle.txt`): the same phase-1 driver
//! ([`super::phase1::drive`]) runs [`GridNodeActor`]s instead of cell nodes
//! and a manager; phase 2 runs the same compositing schedules over their
//! visibility-ranked RGBA layers ([`crate::compositor::layer::exec`]) and
//! replays every message on the simulated network
//! (`super::phase2::replay`).
//!
//! With a master (`--master`, the paper's setting) rank 0 renders nothing
//! and composites; ranks `1..=P` hold the bricks.

use std::collections::BTreeMap;
use std::sync::Arc;

use serde::Serialize;

use super::phase1::{drive, ClockKind};
use super::phase2::{replay, RoundPlan};
use crate::compositor::codec::layers::LayerCodec;
use crate::compositor::layer::exec as layer_exec;
use crate::compositor::layer::Layer;
use crate::compositor::region::screen;
use crate::compositor::strategy::Strategy;
use crate::data::Volume;
use crate::image::Image;
use crate::net::{MessageKind, NetworkModel, SimTrace};
use crate::node::grid::bricks::{extract, place, split, visibility_ranks, Brick, BrickPlacement};
use crate::node::grid::device::{blend_time, check};
use crate::node::grid::render::{whole_planes, RendererKind};
use crate::node::grid::{GridNodeActor, GridNodeStats};
use crate::node::CostProfile;
use crate::render::slice3d::planes::Planes;
use crate::render::slice3d::Slice3dOptions;
use crate::render::slicing::Lut;
use crate::render::VolumeInput;

/// A grid cluster run's settings.
#[derive(Clone)]
pub struct GridConfig {
    /// Rendering nodes `P`.
    pub nodes: usize,
    /// Bricks per axis `d` (`d^3` bricks).
    pub subvolumes: u32,
    /// A master rank that renders nothing (rank 0).
    pub master: bool,
    /// Brick placement.
    pub placement: BrickPlacement,
    /// Compositing strategy.
    pub compositor: crate::compositor::strategy::Compositing,
    /// Layer codec.
    pub codec: crate::compositor::codec::LayerCodecKind,
    /// Slicer options (ERT, slices, classification).
    pub slice: Slice3dOptions,
    /// The brick renderer.
    pub renderer: RendererKind,
    /// Clock.
    pub clock: ClockKind,
    /// Network model and its name.
    pub network: NetworkModel,
    /// Network name.
    pub network_name: String,
    /// Cost profile and its name.
    pub profile: CostProfile,
    /// Profile name.
    pub profile_name: String,
    /// Record the timeline.
    pub record_trace: bool,
    /// Keep each node's brick textures across frames ([`crate::node::grid::cache`];
    /// `false`: prepare every brick every frame, to measure what it saves).
    pub texture_cache: bool,
}

/// Per rank, in the report.
#[derive(Debug, Clone, Serialize)]
pub struct GridNodeReport {
    /// The node's phase-1 numbers.
    #[serde(flatten)]
    pub stats: GridNodeStats,
    /// When it finished rendering (seconds).
    pub render_end_s: f64,
    /// Payload bytes it sent in phase 2.
    pub bytes_sent: u64,
}

/// The report of a grid cluster run (the keys of the cell report that
/// apply, plus the grid's own).
#[derive(Debug, Clone, Serialize)]
pub struct GridReport {
    /// Image size.
    pub image: [u32; 2],
    /// Volume samples per axis.
    pub volume_dims: [u64; 3],
    /// Bricks per axis.
    pub subvolumes: u32,
    /// Rendering nodes.
    pub n_nodes: usize,
    /// With a master rank.
    pub master: bool,
    /// Clock.
    pub clock: ClockKind,
    /// Network name.
    pub network: String,
    /// Profile name.
    pub profile: String,
    /// Placement.
    pub placement: BrickPlacement,
    /// Compositing strategy.
    pub compositor: String,
    /// Layer codec.
    pub codec: String,
    /// Frame time: end of phase 2 (seconds).
    pub frame_s: f64,
    /// Frames per second, `1 / frame_s` (the paper's unit).
    pub fps: f64,
    /// End of phase 1: the slowest node's render (seconds).
    pub render_s: f64,
    /// Phase 2 (compositing, with its network time), seconds.
    pub composite_s: f64,
    /// Payload bytes of phase 2.
    pub bytes_total: u64,
    /// Bytes per message kind.
    pub bytes_by_kind: BTreeMap<String, u64>,
    /// Bytes sent / raw bytes of the same layers at the codec's depth
    /// (RGBA8 or RGBA16).
    pub codec_ratio: f64,
    /// The brick renderer (`slice3d`, or adaptive with its blocks and τ).
    pub renderer: RendererKind,
    /// Texture bytes as rendered ÷ original bytes, over all bricks (the
    /// paper's 縮小率 with adaptive sampling; 1 for slice3d on scalars).
    pub size_ratio: f64,
    /// Preprocessing host seconds (adaptive build, min–max blocks): the
    /// slowest node's sum over its bricks.
    pub prepare_s: f64,
    /// Bricks whose texture alone exceeds a node's texture memory (device
    /// model): when not 0, the paper's hardware could not draw the frame
    /// (its "-"); the times charge them as uploads.
    pub oversized_bricks: u64,
    /// Per round: label, messages, bytes, raw bytes.
    pub rounds: Vec<(String, usize, u64, u64)>,
    /// Per rank.
    pub nodes: Vec<GridNodeReport>,
    /// Host seconds of phase 1 and 2.
    pub host_s: [f64; 2],
    /// Host seconds of the whole frame at the driver (view set-up, phase 1,
    /// phase 2; over a transport, the coordinator's).
    pub wall_s: f64,
    /// Bricks drawn from a texture kept from an earlier frame (all nodes).
    pub textures_cached: u64,
    /// What the transport measured (`--transport processes|tcp`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transport: Option<crate::cluster::remote::grid::GridMeasured>,
}

/// What a grid run produced.
#[derive(Debug)]
pub struct GridOutcome {
    /// The image at the root.
    pub image: Image,
    /// The report.
    pub report: GridReport,
    /// Phase 1 and 2 timeline.
    pub trace: SimTrace,
}

/// What a frame needs before any node renders: the bricks, their
/// visibility ranks and samples, the placement, the whole's slice planes.
pub struct Prepared {
    /// The bricks.
    pub bricks: Vec<Brick>,
    /// Visibility rank of each brick (0 nearest the eye).
    pub ranks: Vec<u32>,
    /// Each brick's samples.
    pub vols: Vec<Arc<Volume>>,
    /// Brick ids of each rendering node.
    pub parts: Vec<Vec<u32>>,
    /// The whole volume's slice planes (`None`: behind the eye).
    pub planes: Option<Planes>,
    /// The layer codec.
    pub codec: Box<dyn LayerCodec>,
    /// The compositing strategy.
    pub strategy: Box<dyn Strategy>,
    /// 1 with a master rank (rank 0 renders nothing), else 0.
    pub off: usize,
    /// Ranks in all (rendering nodes plus the master).
    pub total: usize,
}

impl Prepared {
    /// Rank `k`'s bricks: (brick, its samples, its visibility rank).
    pub fn held(&self, k: usize) -> Vec<(Brick, Arc<Volume>, u32)> {
        if k < self.off {
            return Vec::new();
        }
        self.parts[k - self.off]
            .iter()
            .map(|&b| {
                (
                    self.bricks[b as usize],
                    self.vols[b as usize].clone(),
                    self.ranks[b as usize],
                )
            })
            .collect()
    }
}

/// Checks the settings and cuts, ranks and places the bricks.
pub fn prepare(input: &VolumeInput, cfg: &GridConfig) -> anyhow::Result<Prepared> {
    anyhow::ensure!(cfg.nodes >= 1, "--nodes must be at least 1");
    anyhow::ensure!(
        cfg.nodes <= 4096,
        "--nodes {} is more than grid runs support (4096)",
        cfg.nodes
    );
    if cfg.clock == ClockKind::Virtual {
        check(&cfg.profile, &cfg.profile_name)?;
    }
    cfg.renderer.check(&cfg.slice)?;
    let strategy = cfg.compositor.build();
    let codec = cfg.codec.build();
    let d = cfg.subvolumes;
    let bricks = split(input.volume.dims, d)?;
    anyhow::ensure!(
        bricks.len() >= cfg.nodes,
        "--subvolumes {d} gives {} bricks for {} nodes: some nodes would have none",
        bricks.len(),
        cfg.nodes
    );
    let s = &input.scene;
    let vols: Vec<Arc<Volume>> = bricks
        .iter()
        .map(|b| Arc::new(extract(&input.volume, b)))
        .collect();
    // Balanced placement weighs a brick by its voxels the TF makes visible.
    let lut = Lut::new(&s.transfer, input.range);
    let weight: Vec<u64> = vols
        .iter()
        .map(|v| {
            (0..v.len())
                .filter(|&i| {
                    let x = v.voxels.get_f32(i);
                    !lut.transparent(x, x)
                })
                .count() as u64
        })
        .collect();
    let parts = place(bricks.len(), cfg.nodes, cfg.placement, &weight);
    let off = usize::from(cfg.master);
    let mut prep = Prepared {
        bricks,
        ranks: Vec::new(),
        vols,
        parts,
        planes: None,
        codec,
        strategy,
        off,
        total: cfg.nodes + off,
    };
    prep.view(input, cfg);
    Ok(prep)
}

impl Prepared {
    /// Sets what depends on the view of `input` (same volume, bricks and
    /// transfer function as when prepared): the bricks' visibility ranks
    /// and the whole's slice planes.
    pub fn view(&mut self, input: &VolumeInput, cfg: &GridConfig) {
        let s = &input.scene;
        let view = s.camera.view(s.image.width, s.image.height);
        self.ranks = visibility_ranks(&view, &input.volume, cfg.subvolumes, &self.bricks);
        self.planes = whole_planes(input, &cfg.slice);
    }
}

/// What phase 1 produced, per rank.
pub struct Phase1Out {
    /// Each rank's numbers.
    pub stats: Vec<GridNodeStats>,
    /// Each rank's layers.
    pub layers: Vec<Vec<Layer>>,
    /// When each rank finished rendering (seconds).
    pub ends: Vec<f64>,
    /// Host seconds of phase 1.
    pub host_s: f64,
    /// Phase 1's timeline.
    pub trace: SimTrace,
}

/// Runs one frame of `input` on the grid cluster.
pub fn run(input: &VolumeInput, cfg: &GridConfig) -> anyhow::Result<GridOutcome> {
    let mut out = run_frames(input, cfg, std::slice::from_ref(&input.scene.camera))?;
    Ok(out.pop().expect("one frame"))
}

/// Runs one frame per camera of `cameras` (`input` with each camera in
/// turn) on the same nodes: bricks are cut and placed once, and each node
/// keeps its bricks' textures from frame to frame (unless
/// `cfg.texture_cache` is off), as a cluster keeps what it uploaded.
pub fn run_frames(
    input: &VolumeInput,
    cfg: &GridConfig,
    cameras: &[crate::scene::Camera],
) -> anyhow::Result<Vec<GridOutcome>> {
    anyhow::ensure!(!cameras.is_empty(), "no frame to render");
    let t0 = std::time::Instant::now();
    let mut prep = prepare(input, cfg)?;
    let mut actors: Vec<GridNodeActor> = Vec::new();
    let mut outs = Vec::with_capacity(cameras.len());
    let mut input = input.clone();
    for (f, cam) in cameras.iter().enumerate() {
        let t = if f == 0 {
            t0
        } else {
            std::time::Instant::now()
        };
        input.scene.camera = *cam;
        prep.view(&input, cfg);
        let whole = Arc::new(input.clone());
        if f == 0 {
            actors = (0..prep.total)
                .map(|k| {
                    let a = GridNodeActor::new(
                        k,
                        whole.clone(),
                        prep.planes,
                        prep.held(k),
                        cfg.slice,
                        prep.codec.depth(),
                        cfg.profile,
                        cfg.renderer,
                    );
                    let keep = cfg.texture_cache.then(Default::default);
                    a.with_textures(keep)
                })
                .collect();
        } else {
            for (k, a) in actors.iter_mut().enumerate() {
                let ranks: Vec<u32> = prep.held(k).iter().map(|h| h.2).collect();
                a.next_frame(whole.clone(), prep.planes, &ranks)?;
            }
        }
        let mut out = phase1_and_2(&input, cfg, &prep, &mut actors)?;
        out.report.wall_s = t.elapsed().as_secs_f64();
        outs.push(out);
    }
    Ok(outs)
}

/// One frame on `actors` (set up for it): phase 1, phase 2, the report.
fn phase1_and_2(
    input: &VolumeInput,
    cfg: &GridConfig,
    prep: &Prepared,
    actors: &mut [GridNodeActor],
) -> anyhow::Result<GridOutcome> {
    let t1 = std::time::Instant::now();
    let (stopped, trace1, _traffic1) = drive(
        actors.iter_mut().collect::<Vec<_>>(),
        cfg.clock,
        &cfg.network,
        cfg.record_trace,
        "grid phase 1",
    )?;
    let host_s = t1.elapsed().as_secs_f64();
    if let Some(a) = actors.iter().find(|a| a.stats().error.is_some()) {
        anyhow::bail!(
            "grid node {} failed: {}",
            a.stats().rank,
            a.stats().error.as_deref().unwrap_or("")
        );
    }
    let p1 = Phase1Out {
        stats: actors.iter().map(|a| a.stats().clone()).collect(),
        layers: actors.iter_mut().map(|a| a.take_layers()).collect(),
        ends: stopped.iter().map(|t| t.unwrap_or(0.0)).collect(),
        host_s,
        trace: trace1,
    };
    finish(input, cfg, prep, p1)
}

/// Phase 2 over the ranks' layers (every message encoded and decoded,
/// replayed on the modelled network) and the report.
pub fn finish(
    input: &VolumeInput,
    cfg: &GridConfig,
    prep: &Prepared,
    p1: Phase1Out,
) -> anyhow::Result<GridOutcome> {
    let s = &input.scene;
    let t2 = std::time::Instant::now();
    let sched = prep
        .strategy
        .schedule(prep.total, screen(s.image.width, s.image.height));
    let bg = s.image.background.map(|x| x as f32);
    let (image, rounds) = layer_exec::run(
        &sched,
        prep.codec.as_ref(),
        p1.layers,
        bg,
        prep.strategy.merges_early(),
    )?;
    let p1 = Phase1Out {
        layers: Vec::new(),
        ..p1
    };
    report(input, cfg, prep, p1, image, rounds, t2)
}

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

/// A one-paragraph summary for the terminal.
pub fn summary(r: &GridReport) -> String {
    let mut s = format!(
        "grid cluster: {} node(s){}, {}^3 bricks, {} / {} / {}, {:?} clock\n\
         frame {:.4} s = render {:.4} s + composite {:.4} s; phase-2 bytes {} (codec ratio {:.3})\n\
         renderer {:?}: size ratio {:.3}, preprocessing {:.3} s; bricks over texture memory: {}\n",
        r.n_nodes,
        if r.master { " + master" } else { "" },
        r.subvolumes,
        r.compositor,
        r.codec,
        r.network,
        r.clock,
        r.frame_s,
        r.render_s,
        r.composite_s,
        r.bytes_total,
        r.codec_ratio,
        r.renderer,
        r.size_ratio,
        r.prepare_s,
        r.oversized_bricks
    );
    for n in &r.nodes {
        s.push_str(&format!(
            "  rank {:>2}: bricks {:?} render {:.4} s (fill {:.4}, draw set-up {:.4} for {} textures, upload {:.4} + paging {:.4} for {} B) sent {} B\n",
            n.stats.rank,
            n.stats.bricks,
            n.render_end_s,
            n.stats.device.fill_s,
            n.stats.device.setup_s,
            n.stats.device.textures,
            n.stats.device.upload_s,
            n.stats.device.paging_s,
            n.stats.device.uploaded_bytes,
            n.bytes_sent
        ));
    }
    s
}

#[cfg(test)]
#[path = "grid_tests.rs"]
mod tests;

/// The cameras of `--frames N --turn DEG`: the scene's camera, then the
/// eye turned `k DEG` degrees about the target around the camera's up
/// vector (`eye' = target + R_up(k DEG) (eye - target)`).
pub fn orbit(cam: &crate::scene::Camera, frames: u32, turn_deg: f64) -> Vec<crate::scene::Camera> {
    use glam::{DQuat, DVec3};
    let target = DVec3::from(cam.target);
    let axis = DVec3::from(cam.up).normalize_or_zero();
    (0..frames.max(1))
        .map(|k| {
            let q = DQuat::from_axis_angle(axis, (k as f64 * turn_deg).to_radians());
            let mut c = *cam;
            if k > 0 && axis != DVec3::ZERO {
                c.eye = (target + q * (DVec3::from(cam.eye) - target)).to_array();
            }
            c
        })
        .collect()
}
