//! The grid cluster's driver: bricks cut, ranked and placed
//! ([`prepare`]), phase 1 on the nodes, phase 2 over their layers
//! ([`finish`]), one frame or a series on the same nodes ([`run_frames`]).

use super::{report, GridConfig, GridOutcome};
use std::sync::Arc;

use crate::cluster::phase1::{drive, ClockKind};
use crate::compositor::codec::layers::LayerCodec;
use crate::compositor::layer::exec as layer_exec;
use crate::compositor::layer::Layer;
use crate::compositor::region::screen;
use crate::compositor::strategy::Strategy;
use crate::data::Volume;
use crate::net::SimTrace;
use crate::node::grid::bricks::{extract, place, split, visibility_ranks, Brick};
use crate::node::grid::device::check;
use crate::node::grid::render::whole_planes;
use crate::node::grid::{GridNodeActor, GridNodeStats};
use crate::render::slice3d::planes::Planes;
use crate::render::slicing::Lut;
use crate::render::VolumeInput;

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
