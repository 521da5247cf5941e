//! Grid scenes over `--transport processes|tcp`: the paper's setting, slave
//! processes that render their bricks and send the subimages to a master
//! (`parallel-texture-vr-rle.txt`, PVM over 100BASE), here the coordinator.
//!
//! ```text
//! coordinator → worker  Session::Grid(Setup)  rank, scene (the view), options, bricks' places, SHA-256 of their samples
//! worker → coordinator  Session::Need(bool)   true: the samples are not in its cache
//! coordinator → worker  Session::Cells(bytes) the bricks' samples (grid_wire), only if needed
//!      ... the worker renders its bricks into layers (GridNodeActor, as on the other clocks) ...
//! worker → coordinator  Session::Grid(Result) its stats and its layers, encoded by the layer codec
//! coordinator           decodes the layers strictly and runs phase 2 with the
//!                       same code as the other clocks (cluster::grid::finish)
//! ```
//!
//! A worker gets its bricks once: they are cached by content hash across
//! sessions (as cells are), so a later frame sends only the view. The
//! worker renders with the same code as the threads and the simulator, and
//! the layer codecs are lossless at their depth, so the coordinator holds
//! the same layers bit for bit and composites the same image. Only the
//! master compositor runs here (the workers send to the master, as in the
//! paper); binary swap and direct send between grid workers are refused.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};
use tokio::net::TcpStream;
use tokio::runtime::Runtime;

use super::grid_wire::{
    decode_bricks, encode_bricks, wire_planes, GridSetup, WireBrick, WireSlice,
};
use super::session::{sha256, Session};
use crate::cluster::grid::{finish, prepare, GridConfig, GridOutcome, Phase1Out};
use crate::cluster::ClockKind;
use crate::compositor::codec::layers::from_name as layer_codec;
use crate::compositor::layer::exec as layer_exec;
use crate::compositor::region::{area, screen};
use crate::data::{Volume, Voxels};
use crate::net::tcp::{self, Role, TcpOptions, Token};
use crate::net::{Action, Actor, Codec, Event, NodeId, SimTrace};
use crate::node::grid::cache::BrickTextures;
use crate::node::grid::GridNodeActor;
use crate::node::grid::GridNodeStats;
use crate::render::VolumeInput;
use crate::scene::Scene;

/// The grid messages inside [`Session::Grid`].
#[derive(Debug, Clone, Serialize, Deserialize)]
pub enum GridMsg {
    /// The worker's frame.
    Setup(Box<GridSetup>),
    /// What the worker rendered.
    Result(Box<GridResult>),
}

/// A worker's frame result.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GridResult {
    /// Its numbers (`host_s` is its measured render time).
    pub stats: GridNodeStats,
    /// Its layers cropped to the screen, empty ones dropped, as one
    /// [`layer_exec::encode`] message under the setup's codec.
    pub layers: Vec<u8>,
}

/// What the transport measured, beside the report.
#[derive(Debug, Clone, Default, Serialize)]
pub struct GridMeasured {
    /// `processes` or `tcp`.
    pub transport: String,
    /// Bytes of brick samples sent (0 when every worker had them cached).
    pub bricks_bytes_sent: u64,
    /// Workers that had their bricks cached.
    pub bricks_cached: usize,
    /// Layer message bytes the workers sent (the subimages, encoded).
    pub layer_bytes: u64,
    /// Session payload bytes of the results (layers plus stats).
    pub result_payload_bytes: u64,
    /// Seconds to connect and send set-ups and bricks.
    pub setup_s: f64,
    /// Seconds from the last set-up sent to the last result in.
    pub collect_s: f64,
    /// Seconds of the master's compositing.
    pub composite_s: f64,
}

/// How the coordinator reaches its grid workers.
#[derive(Debug, Clone)]
pub struct GridRemote {
    /// Worker addresses, one per rendering node.
    pub workers: Vec<String>,
    /// The shared token.
    pub token: Token,
    /// Link timing.
    pub tcp: TcpOptions,
    /// Longest wait for a worker's result.
    pub recv_timeout: Duration,
    /// `processes` or `tcp` (for the report).
    pub transport: String,
}

/// A voxel-free volume with the whole's geometry: what a worker's bricks
/// need of the whole (planes, screen rectangles, grid coordinates); no
/// renderer reads the whole's samples (a brick renders from its own).
fn whole_shape(setup: &GridSetup) -> Volume {
    Volume {
        dims: setup.whole_dims,
        spacing: setup.whole_spacing,
        origin: setup.whole_origin,
        field: setup.field.clone(),
        voxels: Voxels::U8(Vec::new()),
    }
}

impl GridRemote {
    /// One frame of `input` on the workers; `cfg.master` must be set.
    pub fn run(
        &self,
        input: &VolumeInput,
        cfg: &GridConfig,
    ) -> anyhow::Result<(GridOutcome, GridMeasured)> {
        anyhow::ensure!(
            cfg.master && cfg.compositor == "master",
            "--transport {} for grid scenes runs the paper's setting: the workers send their \
             subimages to the master (--master); binary swap, direct send and radix-k between \
             grid workers are not built",
            self.transport
        );
        anyhow::ensure!(
            self.workers.len() == cfg.nodes,
            "{} workers for --nodes {}",
            self.workers.len(),
            cfg.nodes
        );
        let mut cfg = cfg.clone();
        cfg.clock = ClockKind::Wall;
        let prep = prepare(input, &cfg)?;
        let codec = Codec::default();
        let rt = tcp::runtime()?;
        let scene_toml = input
            .scene
            .to_toml(&input.scene.data.path.to_string_lossy());
        let t_setup = Instant::now();
        let me = NodeId::from(cfg.nodes);
        let slice = WireSlice::from(&cfg.slice);
        let mut tasks = Vec::with_capacity(cfg.nodes);
        for k in 0..cfg.nodes {
            let rank = k + prep.off;
            let held = prep.held(rank);
            let vols: Vec<&Volume> = held.iter().map(|h| &*h.1).collect();
            let bytes = encode_bricks(&vols);
            let setup = GridSetup {
                rank: rank as u32,
                nodes: prep.total as u32,
                scene_toml: scene_toml.clone(),
                whole_dims: input.volume.dims,
                whole_spacing: input.volume.spacing,
                whole_origin: input.volume.origin,
                field: input.volume.field.clone(),
                range: input.range,
                planes: wire_planes(prep.planes),
                slice,
                renderer: cfg.renderer,
                codec: cfg.codec.clone(),
                profile: cfg.profile,
                bricks: held.iter().map(|h| WireBrick::new(&h.0, h.2)).collect(),
                bricks_sha256: sha256(&bytes),
                max_message_bytes: codec.max_message_bytes,
                texture_cache: cfg.texture_cache,
            };
            let addr = self.workers[k].clone();
            let token = self.token.clone();
            let opts = self.tcp;
            let wait = self.recv_timeout;
            tasks.push(rt.spawn(async move {
                let name = format!("grid worker {k} ({addr})");
                let (mut s, hello) = tcp::connect(&addr, &token, Role::Coordinator, me.0, &opts)
                    .await
                    .map_err(|e| anyhow::anyhow!("{name}, set-up: {e}"))?;
                anyhow::ensure!(
                    hello.role == Role::Worker,
                    "{name}, set-up: answered as {:?}, not as a worker",
                    hello.role
                );
                let d = opts.deadline.max(Duration::from_secs(10));
                let to = NodeId::from(k);
                let msg = Session::Grid(Box::new(GridMsg::Setup(Box::new(setup))));
                tcp::raw::write_msg(&mut s, &codec, me, to, &msg, &name).await?;
                let need: Session = tcp::raw::read_msg(&mut s, &codec, d, &name).await?;
                let sent = match need {
                    Session::Need(true) => {
                        let len = bytes.len() as u64;
                        tcp::raw::write_msg(&mut s, &codec, me, to, &Session::Cells(bytes), &name)
                            .await?;
                        len
                    }
                    Session::Need(false) => 0,
                    Session::Failed(why) => anyhow::bail!("{name}, set-up: {why}"),
                    other => anyhow::bail!("{name}, set-up: sent {other:?} instead of Need"),
                };
                let t_sent = Instant::now();
                let m: Session = tcp::raw::read_msg(&mut s, &codec, wait, &name).await?;
                let payload = codec.encode(&m)?.len() as u64;
                let r = match m {
                    Session::Grid(g) => match *g {
                        GridMsg::Result(r) => r,
                        other => anyhow::bail!("{name}: sent {other:?} instead of its layers"),
                    },
                    Session::Failed(why) => anyhow::bail!("{name}, rendering: {why}"),
                    other => anyhow::bail!("{name}: sent {other:?} instead of its layers"),
                };
                Ok((sent, t_sent, Instant::now(), payload, *r))
            }));
        }
        let mut m = GridMeasured {
            transport: self.transport.clone(),
            ..Default::default()
        };
        let mut results = Vec::with_capacity(cfg.nodes);
        let (mut last_sent, mut last_in) = (t_setup, t_setup);
        let mut first_err = None;
        for t in tasks {
            match rt.block_on(t) {
                Ok(Ok((sent, t_sent, t_in, payload, r))) => {
                    m.bricks_bytes_sent += sent;
                    m.bricks_cached += usize::from(sent == 0);
                    m.result_payload_bytes += payload;
                    m.layer_bytes += r.layers.len() as u64;
                    last_sent = last_sent.max(t_sent);
                    last_in = last_in.max(t_in);
                    results.push(r);
                }
                Ok(Err(e)) => {
                    first_err.get_or_insert(e);
                }
                Err(e) => {
                    first_err.get_or_insert(anyhow::anyhow!("a grid worker task failed: {e}"));
                }
            }
        }
        if let Some(e) = first_err {
            return Err(e);
        }
        m.setup_s = last_sent.duration_since(t_setup).as_secs_f64();
        m.collect_s = last_in.saturating_duration_since(last_sent).as_secs_f64();
        let lc = layer_codec(&cfg.codec).map_err(|e| anyhow::anyhow!(e))?;
        let mut stats = vec![GridNodeStats::default(); prep.total];
        let mut layers = vec![Vec::new(); prep.total];
        let mut ends = vec![0.0; prep.total];
        for (k, r) in results.into_iter().enumerate() {
            let rank = k + prep.off;
            anyhow::ensure!(
                r.stats.rank == rank,
                "grid worker {k} reported rank {} instead of {rank}",
                r.stats.rank
            );
            layers[rank] = layer_exec::decode(lc.as_ref(), &r.layers)
                .map_err(|e| anyhow::anyhow!("the layers of grid worker {k}: {e}"))?;
            ends[rank] = r.stats.host_s;
            stats[rank] = r.stats;
        }
        stats[0].rank = 0;
        let p1 = Phase1Out {
            stats,
            layers,
            ends,
            host_s: m.setup_s + m.collect_s,
            trace: SimTrace::default(),
        };
        let t2 = Instant::now();
        let mut out = finish(input, &cfg, &prep, p1)?;
        m.composite_s = t2.elapsed().as_secs_f64();
        out.report.transport = Some(m.clone());
        Ok((out, m))
    }
}

/// What a grid worker keeps from one session to the next: its last
/// bricks' samples (decoded) and their textures ([`crate::node::grid::cache`]),
/// valid while the set-up names the same brick bytes (SHA-256).
#[derive(Default)]
pub struct GridWorkerCache {
    bricks: Option<([u8; 32], Vec<Arc<Volume>>)>,
    textures: Option<BrickTextures>,
}

/// Serves a grid session on a worker (`setup` came first on `stream`):
/// samples from the cache or the coordinator, the bricks rendered, the
/// layers sent back. `cache` is the worker's content cache.
pub(super) fn serve(
    rt: &Runtime,
    mut stream: TcpStream,
    cache: &mut VecDeque<([u8; 32], Vec<u8>)>,
    cache_entries: usize,
    kept: &mut GridWorkerCache,
    setup: GridSetup,
    coord: NodeId,
    name: &str,
) -> anyhow::Result<()> {
    let codec = Codec::with_limit(setup.max_message_bytes);
    let me = NodeId(setup.rank);
    let d = Duration::from_secs(60);
    let fail = |rt: &Runtime, stream: &mut TcpStream, why: String| -> anyhow::Error {
        let _ = rt.block_on(tcp::raw::write_msg(
            stream,
            &codec,
            me,
            coord,
            &Session::Failed(why.clone()),
            name,
        ));
        anyhow::anyhow!(why)
    };
    if let Err(e) = setup.validate() {
        return Err(fail(
            rt,
            &mut stream,
            format!("bad grid set-up from {name}: {e}"),
        ));
    }
    let cached = cache.iter().position(|(h, _)| *h == setup.bricks_sha256);
    rt.block_on(tcp::raw::write_msg(
        &mut stream,
        &codec,
        me,
        coord,
        &Session::Need(cached.is_none()),
        name,
    ))?;
    let bytes = match cached {
        Some(i) => cache[i].1.clone(),
        None => {
            let m: Session = rt.block_on(tcp::raw::read_msg(&mut stream, &codec, d, name))?;
            let Session::Cells(bytes) = m else {
                anyhow::bail!("{name} sent {m:?} instead of the bricks");
            };
            anyhow::ensure!(
                sha256(&bytes) == setup.bricks_sha256,
                "the bricks from {name} do not match their SHA-256"
            );
            if cache.len() >= cache_entries {
                cache.pop_front();
            }
            cache.push_back((setup.bricks_sha256, bytes.clone()));
            bytes
        }
    };
    let result = render(&setup, &bytes, kept).map_err(|e| fail(rt, &mut stream, format!("{e:#}")))?;
    let msg = Session::Grid(Box::new(GridMsg::Result(Box::new(result))));
    rt.block_on(tcp::raw::write_msg(
        &mut stream,
        &codec,
        me,
        coord,
        &msg,
        name,
    ))?;
    // Wait for the coordinator to close, so that nothing is cut short.
    let _ = rt.block_on(tcp::raw::read_msg::<_, Session>(
        &mut stream,
        &codec,
        d,
        name,
    ));
    Ok(())
}

/// Renders the set-up's bricks with the same actor as the other clocks.
fn render(
    setup: &GridSetup,
    bytes: &[u8],
    kept: &mut GridWorkerCache,
) -> anyhow::Result<GridResult> {
    let vols: Vec<Arc<Volume>> = match &kept.bricks {
        Some((h, v)) if *h == setup.bricks_sha256 => v.clone(),
        _ => {
            kept.textures = None;
            let v: Vec<Arc<Volume>> = decode_bricks(bytes, &setup.field)
                .map_err(|e| anyhow::anyhow!(e))?
                .into_iter()
                .map(Arc::new)
                .collect();
            kept.bricks = Some((setup.bricks_sha256, v.clone()));
            v
        }
    };
    anyhow::ensure!(
        vols.len() == setup.bricks.len(),
        "{} bricks' samples for {} bricks",
        vols.len(),
        setup.bricks.len()
    );
    for (v, b) in vols.iter().zip(&setup.bricks) {
        anyhow::ensure!(
            v.dims == b.dims,
            "brick {}: samples {:?} for a brick of {:?}",
            b.id,
            v.dims,
            b.dims
        );
    }
    let scene = Scene::parse(
        &setup.scene_toml,
        std::path::Path::new("(scene from the coordinator)"),
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let (w, h) = (scene.image.width, scene.image.height);
    let whole = Arc::new(VolumeInput {
        scene,
        volume: Arc::new(whole_shape(setup)),
        range: setup.range,
    });
    let lc = layer_codec(&setup.codec).map_err(|e| anyhow::anyhow!(e))?;
    let opts = setup.slice.options().map_err(|e| anyhow::anyhow!(e))?;
    setup.renderer.check(&opts)?;
    let held = setup
        .bricks
        .iter()
        .zip(vols)
        .map(|(b, v)| (b.brick(), v, b.rank))
        .collect();
    let mut actor = GridNodeActor::new(
        setup.rank as usize,
        whole,
        setup.planes(),
        held,
        opts,
        lc.depth(),
        setup.profile,
        setup.renderer,
    )
    .with_textures(if setup.texture_cache {
        Some(kept.textures.take().unwrap_or_default())
    } else {
        None
    });
    let actions = actor.handle(0.0, Event::Start);
    kept.textures = actor.take_textures();
    debug_assert!(actions.iter().any(|a| matches!(a, Action::Stop)));
    if let Some(e) = &actor.stats().error {
        anyhow::bail!("grid node {}: {e}", setup.rank);
    }
    let full = screen(w, h);
    let layers: Vec<_> = actor
        .take_layers()
        .iter()
        .map(|l| l.crop(&full))
        .filter(|l| area(&l.rect) > 0)
        .collect();
    let (layers, _) = layer_exec::encode(lc.as_ref(), &layers);
    Ok(GridResult {
        stats: actor.stats().clone(),
        layers,
    })
}
