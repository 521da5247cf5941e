//! What a grid frame holds between its stages: the prepared bricks and
//! placement ([`Prepared`], made by the driver's `prepare`) and phase 1's
//! per-rank results ([`Phase1Out`]); the driver runs the stages, the
//! report builder reads both.

use super::GridConfig;
use std::sync::Arc;

use crate::cluster::phase1::ClockKind;
use crate::compositor::codec::layers::LayerCodec;
use crate::compositor::layer::Layer;
use crate::compositor::strategy::Strategy;
use crate::data::Volume;
use crate::net::SimTrace;
use crate::node::grid::bricks::{extract, place, split, visibility_ranks, Brick};
use crate::node::grid::device::check;
use crate::node::grid::render::whole_planes;
use crate::node::grid::GridNodeStats;
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
