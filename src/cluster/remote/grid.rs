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
use super::phase2::{decode_message, run_partial, RankLog};
use super::session::{sha256, Session};
use crate::cluster::grid::{finish, prepare, report, GridConfig, GridOutcome, Phase1Out};
use crate::cluster::ClockKind;
use crate::compositor::codec::layers::from_name as layer_codec;
use crate::compositor::layer::exec as layer_exec;
use crate::compositor::layer::rank::{LayerGather, LayerRank};
use crate::compositor::layer::Layer;
use crate::compositor::region::{area, screen};
use crate::compositor::{Payload, RoundKind, Schedule};
use crate::data::{Volume, Voxels};
use crate::net::tcp::{self, Link, Role, TcpOptions, TcpTransport, Token};
use crate::net::{
    Action, Actor, Codec, Event, MessageKind, NodeId, RemoteTransport, SimTrace, Transport,
};
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
    /// Phase 2 worker to worker: the rank's log, after its last send.
    Done(Box<RankLog>),
}

/// A worker's frame result.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GridResult {
    /// Its numbers (`host_s` is its measured render time).
    pub stats: GridNodeStats,
    /// Its layers cropped to the screen, empty ones dropped, as one
    /// [`layer_exec::encode`] message under the setup's codec (empty when
    /// the workers composite among themselves).
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
    /// One frame of `input` on the workers. With a master (`cfg.master`)
    /// the workers send their layers to the coordinator, which composites
    /// (the paper); without, they run the compositor's schedule among
    /// themselves ([`super::phase2::run_partial`]) and only the final
    /// pixels reach the coordinator.
    pub fn run(
        &self,
        input: &VolumeInput,
        cfg: &GridConfig,
    ) -> anyhow::Result<(GridOutcome, GridMeasured)> {
        anyhow::ensure!(
            !cfg.master || cfg.compositor == "master",
            "--master composites every subimage at the master; it cannot be combined with \
             --compositor {}",
            cfg.compositor
        );
        anyhow::ensure!(
            self.workers.len() == cfg.nodes,
            "{} workers for --nodes {}",
            self.workers.len(),
            cfg.nodes
        );
        let p2p = !cfg.master;
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
                peers: if p2p {
                    self.workers.clone()
                } else {
                    Vec::new()
                },
                compositor: cfg.compositor.clone(),
                bricks_total: prep.bricks.len() as u32,
                recv_timeout_s: self.recv_timeout.as_secs_f64(),
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
                if p2p {
                    return Ok(Reply::Stream(
                        Box::new(Link {
                            rank: to,
                            name,
                            stream: s,
                        }),
                        sent,
                        t_sent,
                    ));
                }
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
                Ok(Reply::Result(sent, t_sent, Instant::now(), payload, r))
            }));
        }
        let mut m = GridMeasured {
            transport: self.transport.clone(),
            ..Default::default()
        };
        let mut results = Vec::with_capacity(cfg.nodes);
        let mut links = Vec::new();
        let (mut last_sent, mut last_in) = (t_setup, t_setup);
        let mut first_err = None;
        for t in tasks {
            match rt.block_on(t) {
                Ok(Ok(Reply::Result(sent, t_sent, t_in, payload, r))) => {
                    m.bricks_bytes_sent += sent;
                    m.bricks_cached += usize::from(sent == 0);
                    m.result_payload_bytes += payload;
                    m.layer_bytes += r.layers.len() as u64;
                    last_sent = last_sent.max(t_sent);
                    last_in = last_in.max(t_in);
                    results.push(*r);
                }
                Ok(Ok(Reply::Stream(link, sent, t_sent))) => {
                    m.bricks_bytes_sent += sent;
                    m.bricks_cached += usize::from(sent == 0);
                    last_sent = last_sent.max(t_sent);
                    links.push(*link);
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
        if p2p {
            m.setup_s = last_sent.duration_since(t_setup).as_secs_f64();
            let opts = TcpOptions { codec, ..self.tcp };
            let t = TcpTransport::new(rt.clone(), me, cfg.nodes + 1, links, opts)?;
            let r = self.collect_p2p(&t, input, &cfg, &prep, &mut m, last_sent);
            t.close(Duration::from_secs(2));
            let mut out = r?;
            out.report.transport = Some(m.clone());
            return Ok((out, m));
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

/// What a coordinator's set-up task ends with.
enum Reply {
    /// With a master: the worker's result (bytes of samples sent, when the
    /// set-up was sent, when the result came in, its payload bytes).
    Result(u64, Instant, Instant, u64, Box<GridResult>),
    /// Worker to worker: the link, kept for the frame's transport.
    Stream(Box<Link>, u64, Instant),
}

impl GridRemote {
    /// The coordinator's side of a frame composited worker to worker: each
    /// worker's stats, the gathered pixels (pieces, and the root's own as
    /// raw f32), each rank's log; then the report from the logs.
    fn collect_p2p(
        &self,
        t: &TcpTransport,
        input: &VolumeInput,
        cfg: &GridConfig,
        prep: &crate::cluster::grid::Prepared,
        m: &mut GridMeasured,
        t_sent: Instant,
    ) -> anyhow::Result<GridOutcome> {
        let codec = Codec::default();
        let n = cfg.nodes;
        for k in 0..n {
            t.set_essential(NodeId::from(k), true);
        }
        let s = &input.scene;
        let sched = prep
            .strategy
            .schedule(prep.total, screen(s.image.width, s.image.height));
        sched.validate().map_err(|e| anyhow::anyhow!(e))?;
        let lc = layer_codec(&cfg.codec).map_err(|e| anyhow::anyhow!(e))?;
        let mut gather = LayerGather::new(lc.as_ref(), sched.image);
        let mut stats: Vec<Option<GridNodeStats>> = vec![None; n];
        let mut logs: Vec<Option<RankLog>> = vec![None; n];
        let mut t_in = t_sent;
        let mut t2 = None;
        while logs.iter().any(Option::is_none) {
            let e = t.recv_timeout(self.recv_timeout)?.ok_or_else(|| {
                anyhow::anyhow!(
                    "grid workers {:?} sent nothing within {:.0} s",
                    (0..n).filter(|&k| logs[k].is_none()).collect::<Vec<_>>(),
                    self.recv_timeout.as_secs_f64()
                )
            })?;
            let from = e.from.index();
            let name = t.peer_name(e.from);
            anyhow::ensure!(from < n, "a message from {name}, not a grid worker");
            match e.kind {
                MessageKind::Image => {
                    let (r, what, body) = decode_message(&e.payload)
                        .map_err(|why| anyhow::anyhow!("phase 2, gather: {name}: {why}"))?;
                    let ok = sched
                        .rounds
                        .get(r as usize)
                        .is_some_and(|x| x.kind == RoundKind::Gather)
                        && matches!(what, Payload::Pixels(_));
                    anyhow::ensure!(ok, "phase 2, gather: {name} sent a message for round {r}, not a gather of pixels");
                    let taken = if from == sched.root {
                        gather.take_handoff(what.rect(), body)
                    } else {
                        gather.take(what.rect(), body)
                    };
                    taken.map_err(|e| anyhow::anyhow!("phase 2, gather: {name}: {e}"))?;
                }
                MessageKind::Session => match codec.decode::<Session>(&e.payload)? {
                    Session::Grid(g) => match *g {
                        GridMsg::Result(r) if stats[from].is_none() => {
                            t_in = t_in.max(Instant::now());
                            anyhow::ensure!(
                                r.stats.rank == from,
                                "{name} reported rank {} instead of {from}",
                                r.stats.rank
                            );
                            t2.get_or_insert_with(Instant::now);
                            stats[from] = Some(r.stats);
                        }
                        GridMsg::Done(log) if stats[from].is_some() && logs[from].is_none() => {
                            anyhow::ensure!(
                                log.merged.len() == sched.rounds.len()
                                    && log
                                        .sent
                                        .iter()
                                        .all(|s| (s.round as usize) < sched.rounds.len()
                                            && (s.to as usize) < n),
                                "{name} sent a phase-2 log that does not fit the schedule"
                            );
                            t.set_essential(e.from, false);
                            logs[from] = Some(*log);
                        }
                        other => anyhow::bail!("{name} sent {other:?} out of turn"),
                    },
                    Session::Failed(why) => anyhow::bail!("{name}: {why}"),
                    other => anyhow::bail!("{name} sent {other:?} out of turn"),
                },
                k => anyhow::bail!("{name} sent a {k:?} message to the coordinator"),
            }
        }
        m.collect_s = t_in.saturating_duration_since(t_sent).as_secs_f64();
        let t2 = t2.unwrap_or_else(Instant::now);
        let stats: Vec<GridNodeStats> = stats.into_iter().map(Option::unwrap_or_default).collect();
        let logs: Vec<RankLog> = logs.into_iter().map(Option::unwrap_or_default).collect();
        let rounds = layer_rounds(&sched, &logs);
        m.layer_bytes = rounds
            .iter()
            .flat_map(|r| &r.messages)
            .map(|x| x.bytes)
            .sum();
        let p1 = Phase1Out {
            ends: stats.iter().map(|s| s.host_s).collect(),
            stats,
            layers: Vec::new(),
            host_s: m.setup_s + m.collect_s,
            trace: SimTrace::default(),
        };
        let bg = s.image.background.map(|x| x as f32);
        let out = report(input, cfg, prep, p1, gather.image(bg), rounds, t2)?;
        m.composite_s = t2.elapsed().as_secs_f64();
        Ok(out)
    }
}

/// The rounds of the in-process executor ([`layer_exec::LayerRound`]) from
/// the ranks' logs: the same messages in the same order (by sender, each
/// sender's in schedule order), blends and early merges.
fn layer_rounds(sched: &Schedule, logs: &[RankLog]) -> Vec<layer_exec::LayerRound> {
    let n = sched.nodes;
    sched
        .rounds
        .iter()
        .enumerate()
        .map(|(r, round)| layer_exec::LayerRound {
            label: round.label.clone(),
            composite: round.kind == RoundKind::Composite,
            blended: logs
                .iter()
                .map(|l| match l.composite {
                    Some((cr, px, _)) if cr as usize == r => px,
                    _ => 0,
                })
                .collect(),
            merged: (0..n).map(|k| logs[k].merged[r].blended).collect(),
            messages: logs
                .iter()
                .enumerate()
                .flat_map(|(k, l)| {
                    l.sent
                        .iter()
                        .filter(move |s| s.round as usize == r)
                        .map(move |s| layer_exec::LayerMessage {
                            from: k,
                            to: s.to as usize,
                            bytes: s.bytes,
                            raw_bytes: s.raw_bytes,
                            pixels: s.pixels,
                        })
                })
                .collect(),
        })
        .collect()
}

/// What a grid worker needs of its process to join a mesh of peers.
pub struct Mesh<'a> {
    /// The process's runtime.
    pub rt: &'a Arc<Runtime>,
    /// Its listener (peers of higher rank dial it).
    pub listener: &'a tokio::net::TcpListener,
    /// The shared token.
    pub token: &'a Token,
    /// Link timing.
    pub opts: &'a TcpOptions,
}

impl Mesh<'_> {
    /// This rank's transport to its peers and the coordinator: dials the
    /// lower ranks and accepts the higher ones ([`super::worker::mesh`]),
    /// adds the coordinator's link (`coord`, the session's stream), and
    /// runs them with `codec`'s frame limit.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn transport(
        &self,
        rank: u32,
        nodes: u32,
        peers: &[String],
        coord: NodeId,
        name: String,
        stream: TcpStream,
        codec: Codec,
    ) -> anyhow::Result<TcpTransport> {
        let mut links = self.rt.block_on(super::worker::mesh(
            self.listener,
            self.token,
            self.opts,
            rank,
            nodes,
            peers,
        ))?;
        links.push(Link {
            rank: coord,
            name,
            stream,
        });
        let opts = TcpOptions {
            codec,
            ..*self.opts
        };
        Ok(TcpTransport::new(
            Arc::clone(self.rt),
            NodeId(rank),
            nodes as usize + 1,
            links,
            opts,
        )?)
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
#[allow(clippy::too_many_arguments)]
pub(super) fn serve(
    rt: &Runtime,
    mut stream: TcpStream,
    cache: &mut VecDeque<([u8; 32], Vec<u8>)>,
    cache_entries: usize,
    kept: &mut GridWorkerCache,
    mesh: Mesh,
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
    if !setup.peers.is_empty() {
        return serve_p2p(stream, kept, mesh, &setup, &bytes, coord, name);
    }
    let result = render(&setup, &bytes, kept)
        .and_then(|(stats, layers)| {
            let lc = layer_codec(&setup.codec).map_err(|e| anyhow::anyhow!(e))?;
            let (layers, _) = layer_exec::encode(lc.as_ref(), &layers);
            Ok(GridResult { stats, layers })
        })
        .map_err(|e| fail(rt, &mut stream, format!("{e:#}")))?;
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

/// A grid worker's frame composited worker to worker: join the mesh of
/// peers (dial lower ranks, accept higher ones), render, send the stats to
/// the coordinator, run this rank's part of the schedule over the mesh
/// ([`super::phase2::run_partial`] with a [`LayerRank`]), send the log. Any
/// error is reported to the coordinator (`Failed`) before the links close.
fn serve_p2p(
    stream: TcpStream,
    kept: &mut GridWorkerCache,
    mesh: Mesh,
    setup: &GridSetup,
    bytes: &[u8],
    coord: NodeId,
    name: &str,
) -> anyhow::Result<()> {
    let codec = Codec::with_limit(setup.max_message_bytes);
    let t = mesh.transport(
        setup.rank,
        setup.nodes,
        &setup.peers,
        coord,
        name.to_string(),
        stream,
        codec,
    )?;
    t.set_essential(coord, true);
    let r = frame_p2p(&t, kept, setup, bytes, coord);
    match r {
        Ok(()) => {
            t.close(Duration::from_secs(10));
            Ok(())
        }
        Err(e) => {
            let why = format!("grid node {}: {e:#}", setup.rank);
            let _ = codec
                .encode(&Session::Failed(why.clone()))
                .map(|b| t.send(coord, MessageKind::Session, b));
            t.close(Duration::from_secs(2));
            anyhow::bail!(why)
        }
    }
}

/// Render, stats to the coordinator, phase 2 over `t`, the log.
fn frame_p2p(
    t: &TcpTransport,
    kept: &mut GridWorkerCache,
    setup: &GridSetup,
    bytes: &[u8],
    coord: NodeId,
) -> anyhow::Result<()> {
    let codec = Codec::with_limit(setup.max_message_bytes);
    let (stats, layers) = render(setup, bytes, kept)?;
    let result = GridResult {
        stats,
        layers: Vec::new(),
    };
    let msg = Session::Grid(Box::new(GridMsg::Result(Box::new(result))));
    t.send(coord, MessageKind::Session, codec.encode(&msg)?)?;
    let scene = Scene::parse(
        &setup.scene_toml,
        std::path::Path::new("(scene from the coordinator)"),
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let strategy = crate::compositor::strategy::from_name(&setup.compositor)
        .map_err(|e| anyhow::anyhow!(e))?;
    let sched = strategy.schedule(
        setup.nodes as usize,
        screen(scene.image.width, scene.image.height),
    );
    sched.validate().map_err(|e| anyhow::anyhow!(e))?;
    let lc = layer_codec(&setup.codec).map_err(|e| anyhow::anyhow!(e))?;
    let mut state = LayerRank::new(
        lc.as_ref(),
        sched.image,
        layers,
        setup.bricks_total,
        strategy.merges_early(),
    );
    let log = run_partial(
        t,
        setup.rank as usize,
        coord,
        &sched,
        &mut state,
        Vec::new(),
        Duration::from_secs_f64(setup.recv_timeout_s),
    )?;
    let msg = Session::Grid(Box::new(GridMsg::Done(Box::new(log))));
    t.send(coord, MessageKind::Session, codec.encode(&msg)?)?;
    Ok(())
}

/// Renders the set-up's bricks with the same actor as the other clocks.
fn render(
    setup: &GridSetup,
    bytes: &[u8],
    kept: &mut GridWorkerCache,
) -> anyhow::Result<(GridNodeStats, Vec<Layer>)> {
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
    let layers: Vec<Layer> = actor
        .take_layers()
        .iter()
        .map(|l| l.crop(&full))
        .filter(|l| area(&l.rect) > 0)
        .collect();
    Ok((actor.stats().clone(), layers))
}
