//! The grid node as a [`crate::net::Actor`]: on `Start` it renders its
//! bricks into layers (the real work, inside `handle`), charges the modelled
//! time ([`super::device`]) as one `Compute`, and stops. Grid nodes need no
//! manager traffic: sort-last rendering of bricks has no load exchange.

use std::sync::Arc;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::compositor::layer::{Depth, Layer};
use crate::data::Volume;
use crate::net::{Action, Activity, Actor, Event};
use crate::node::CostProfile;
use crate::render::slice3d::planes::Planes;
use crate::render::slice3d::Slice3dOptions;
use crate::render::VolumeInput;

use super::bricks::Brick;
use super::cache::{BrickTextures, TextureKey};
use super::device::{device_bytes, frame_time, BrickWork, DeviceTime};
use super::render::{render_brick, BrickRenderer, LayerSpec, RendererKind};
use crate::render::slice3d;

/// What a grid node did.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct GridNodeStats {
    /// Rank.
    pub rank: usize,
    /// Brick ids rendered.
    pub bricks: Vec<u32>,
    /// Modelled time by part.
    pub device: DeviceTime,
    /// Slice samples inside the node's bricks (fragments).
    pub fragments: u64,
    /// Samples the slicer took.
    pub samples_taken: u64,
    /// Subimage pixels.
    pub pixels: u64,
    /// Texture bytes of its bricks as rendered (reduced bytes with
    /// adaptive sampling).
    pub texture_bytes: u64,
    /// Bytes of its bricks' original samples.
    pub original_bytes: u64,
    /// Host seconds of the renderer's preprocessing (min–max blocks, or the
    /// adaptive build), summed over its bricks.
    pub prepare_s: f64,
    /// Host seconds spent rendering.
    pub host_s: f64,
    /// Thread CPU seconds of the same render ([`crate::net::cpu`]).
    #[serde(default)]
    pub cpu_s: f64,
    /// Process CPU seconds of the same render: the slicer's worker threads
    /// included (the node's CPU time when it has its process to itself,
    /// as a worker process does; with several nodes in one process it
    /// includes theirs).
    #[serde(default)]
    pub process_cpu_s: f64,
    /// Minor page faults of the process during the render (a fresh worker
    /// process's first touch of its buffers; [`crate::net::cpu::minor_faults`]).
    #[serde(default)]
    pub minor_faults: u64,
    /// Bricks whose texture came from the node's cache this frame (kept
    /// from an earlier frame; `slice3d` only).
    #[serde(default)]
    pub textures_cached: u64,
    /// The error that stopped the node, if any.
    pub error: Option<String>,
}

/// One grid node.
pub struct GridNodeActor {
    whole: Arc<VolumeInput>,
    planes: Option<Planes>,
    bricks: Vec<(Brick, Arc<Volume>, u32)>,
    opts: Slice3dOptions,
    depth: Depth,
    profile: CostProfile,
    renderer: BrickRenderer,
    kind: RendererKind,
    layers: Vec<Layer>,
    stats: GridNodeStats,
    textures: Option<BrickTextures>,
}

impl GridNodeActor {
    /// A node of rank `rank` holding `bricks` (brick, its samples, its
    /// visibility rank), rendering with the whole's `planes` into layers of
    /// `depth`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        rank: usize,
        whole: Arc<VolumeInput>,
        planes: Option<Planes>,
        bricks: Vec<(Brick, Arc<Volume>, u32)>,
        opts: Slice3dOptions,
        depth: Depth,
        profile: CostProfile,
        kind: RendererKind,
    ) -> GridNodeActor {
        let stats = GridNodeStats {
            rank,
            bricks: bricks.iter().map(|b| b.0.id).collect(),
            ..Default::default()
        };
        GridNodeActor {
            whole,
            planes,
            bricks,
            opts,
            depth,
            profile,
            renderer: kind.build(),
            kind,
            layers: Vec::new(),
            stats,
            textures: Some(BrickTextures::default()),
        }
    }

    /// Keeps (`Some`, the default: an empty cache) or drops (`None`: every
    /// frame prepares every brick again, the behaviour before the cache)
    /// the node's brick textures ([`super::cache`]). A cache taken from an
    /// earlier node ([`GridNodeActor::take_textures`]) carries its textures
    /// over; entries whose samples or options differ are rebuilt.
    pub fn with_textures(mut self, textures: Option<BrickTextures>) -> GridNodeActor {
        self.textures = textures;
        self
    }

    /// The node's brick textures (to hand to the next frame's node).
    pub fn take_textures(&mut self) -> Option<BrickTextures> {
        self.textures.take()
    }

    /// Sets up the next frame on the same node (same bricks and samples,
    /// so the cached textures stay valid): the whole's input (the new
    /// view), its slice planes, and each held brick's visibility rank, in
    /// the order the bricks were given. Clears the last frame's layers and
    /// numbers.
    pub fn next_frame(
        &mut self,
        whole: Arc<VolumeInput>,
        planes: Option<Planes>,
        ranks: &[u32],
    ) -> crate::error::Result<()> {
        if ranks.len() != self.bricks.len() {
            return Err(crate::error::Error::Invalid(format!(
                "internal: {} visibility ranks for the {} bricks of node {}",
                ranks.len(),
                self.bricks.len(),
                self.stats.rank
            )));
        }
        for (b, &r) in self.bricks.iter_mut().zip(ranks) {
            b.2 = r;
        }
        self.whole = whole;
        self.planes = planes;
        self.layers.clear();
        self.stats = GridNodeStats {
            rank: self.stats.rank,
            bricks: self.stats.bricks.clone(),
            ..Default::default()
        };
        Ok(())
    }

    /// The statistics.
    pub fn stats(&self) -> &GridNodeStats {
        &self.stats
    }

    /// The layers rendered (after the run).
    pub fn take_layers(&mut self) -> Vec<Layer> {
        std::mem::take(&mut self.layers)
    }

    fn render(&mut self) -> crate::error::Result<f64> {
        let t = Instant::now();
        let cpu0 = crate::net::cpu::thread_cpu_s();
        let pcpu0 = crate::net::cpu::process_cpu_s();
        let faults0 = crate::net::cpu::minor_faults();
        let mut work = Vec::with_capacity(self.bricks.len());
        if let Some(planes) = self.planes {
            for (b, vol, rank) in &self.bricks {
                let spec = LayerSpec {
                    rank: *rank,
                    depth: self.depth,
                };
                let out = match (&mut self.textures, self.kind) {
                    // slice3d over the brick's kept texture.
                    (Some(cache), RendererKind::Slice3d) => {
                        let input = VolumeInput {
                            scene: self.whole.scene.clone(),
                            volume: vol.clone(),
                            range: self.whole.range,
                        };
                        let key = TextureKey::new(&input, self.opts.classify);
                        let (prep, fresh) = cache.get(b.id, vol, &key, &input);
                        self.stats.textures_cached += u64::from(!fresh);
                        let r = move |i: &VolumeInput, o: &Slice3dOptions| {
                            let (img, mut st) = slice3d::render_prepared(i, &prep, o)?;
                            st.time_prepare_s = if fresh { prep.time_s } else { 0.0 };
                            Ok((img, st))
                        };
                        render_brick(&self.whole, planes, b, vol.clone(), spec, &self.opts, &r)?
                    }
                    _ => render_brick(
                        &self.whole,
                        planes,
                        b,
                        vol.clone(),
                        spec,
                        &self.opts,
                        &*self.renderer,
                    )?,
                };
                let st = &out.stats;
                // Stored bytes per sample: 4 with pre-classification (RGBA8),
                // else the scalar's size.
                let per_sample = if self.opts.classify == crate::render::slicing::Classify::Pre {
                    4
                } else {
                    vol.voxels.bytes() / vol.len().max(1)
                };
                let w = BrickWork {
                    texture_bytes: device_bytes(st.texture_bytes, per_sample, &self.profile),
                    fragments: st.samples_taken + st.samples_skipped_empty + st.samples_skipped_ert,
                    samples_taken: st.samples_taken,
                    pixels: out.layer.px.len() as u64,
                    textures: self.kind.textures(vol.dims),
                };
                self.stats.texture_bytes += st.texture_bytes;
                self.stats.original_bytes += vol.voxels.bytes();
                self.stats.prepare_s += st.time_prepare_s;
                self.stats.fragments += w.fragments;
                self.stats.samples_taken += w.samples_taken;
                self.stats.pixels += w.pixels;
                work.push(w);
                self.layers.push(out.layer);
            }
        }
        self.stats.device = frame_time(&work, &self.profile);
        self.stats.host_s = t.elapsed().as_secs_f64();
        self.stats.cpu_s = crate::net::cpu::thread_cpu_s() - cpu0;
        self.stats.process_cpu_s = crate::net::cpu::process_cpu_s() - pcpu0;
        self.stats.minor_faults = crate::net::cpu::minor_faults().saturating_sub(faults0);
        Ok(self.stats.device.total())
    }
}

impl Actor for GridNodeActor {
    fn handle(&mut self, _now: f64, event: Event) -> Vec<Action> {
        match event {
            Event::Start => match self.render() {
                Ok(s) => vec![
                    Action::Compute {
                        seconds: s,
                        activity: Activity::Scan,
                    },
                    Action::Stop,
                ],
                Err(e) => {
                    self.stats.error = Some(e.to_string());
                    vec![Action::Stop]
                }
            },
            _ => Vec::new(),
        }
    }
}
