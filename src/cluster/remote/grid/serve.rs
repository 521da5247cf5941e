//! The worker's side of a grid session: the bricks' samples from the cache
//! or the coordinator, the bricks rendered into layers, then the layers
//! sent to the master, or composited worker to worker.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;

use tokio::net::TcpStream;
use tokio::runtime::Runtime;

use super::{GridMsg, GridResult};
use crate::cluster::remote::grid_wire::{decode_bricks, GridSetup};
use crate::cluster::remote::guard::{close_failed, given_up_while_stopped, report_failure};
use crate::cluster::remote::hooks::{kill_self, Hooks};
use crate::cluster::remote::mesh::Mesh;
use crate::cluster::remote::phase2::run_partial;
use crate::cluster::remote::session::{sha256, Session};
use crate::compositor::layer::exec as layer_exec;
use crate::compositor::layer::rank::LayerRank;
use crate::compositor::layer::Layer;
use crate::compositor::region::{area, screen};
use crate::data::{Volume, Voxels};
use crate::net::tcp::{self, TcpTransport};
use crate::net::{Action, Actor, Codec, Event, MessageKind, NodeId, RemoteTransport, Transport};
use crate::node::grid::cache::BrickTextures;
use crate::node::grid::GridNodeActor;
use crate::node::grid::GridNodeStats;
use crate::render::VolumeInput;
use crate::scene::Scene;

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
pub(in crate::cluster::remote) fn serve(
    rt: &Runtime,
    mut stream: TcpStream,
    cache: &mut VecDeque<([u8; 32], Vec<u8>)>,
    cache_entries: usize,
    kept: &mut GridWorkerCache,
    mesh: Mesh,
    setup: GridSetup,
    coord: NodeId,
    name: &str,
    hooks: Hooks,
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
        return serve_p2p(stream, kept, mesh, &setup, &bytes, coord, name, hooks);
    }
    serve_master(stream, kept, mesh, &setup, &bytes, coord, name, hooks)
}

/// A grid worker's frame with a master: the coordinator's link becomes a
/// transport (heartbeats both ways while the bricks render, so a stalled
/// or dead coordinator is noticed within the deadline, and the coordinator
/// notices a stalled worker), then the layers go to the coordinator, and
/// the worker waits for the coordinator to close the link.
#[allow(clippy::too_many_arguments)]
fn serve_master(
    stream: TcpStream,
    kept: &mut GridWorkerCache,
    mesh: Mesh,
    setup: &GridSetup,
    bytes: &[u8],
    coord: NodeId,
    name: &str,
    hooks: Hooks,
) -> anyhow::Result<()> {
    let since = std::time::Instant::now();
    let codec = Codec::with_limit(setup.max_message_bytes);
    anyhow::ensure!(
        coord.0 == setup.nodes,
        "{name} says it is rank {}, but the grid set-up has {} ranks",
        coord.0,
        setup.nodes
    );
    let link = tcp::Link {
        rank: coord,
        name: name.to_string(),
        stream,
    };
    let opts = tcp::TcpOptions {
        codec,
        ..*mesh.opts
    };
    let t = TcpTransport::new(
        Arc::clone(mesh.rt),
        NodeId(setup.rank),
        setup.nodes as usize + 1,
        vec![link],
        opts,
    )?;
    t.set_essential(coord, true);
    if hooks.kill_after_chunks.is_some() {
        kill_self("while rendering its bricks (--test-kill-after-chunks)");
    }
    let result = render(setup, bytes, kept).and_then(|(stats, layers)| {
        let early = queued_unless_given_up(&t)?;
        given_up_while_stopped(&t, since)?;
        anyhow::ensure!(
            early.is_empty(),
            "{} unexpected message(s) from the coordinator while rendering",
            early.len()
        );
        let lc = setup.codec.build();
        let (layers, _) = layer_exec::encode(lc.as_ref(), &layers);
        Ok(GridResult { stats, layers })
    });
    let msg = match &result {
        Ok(r) => Session::Grid(Box::new(GridMsg::Result(Box::new(r.clone())))),
        Err(e) => Session::Failed(format!("grid node {}: {e:#}", setup.rank)),
    };
    t.send(coord, MessageKind::Session, codec.encode(&msg)?)?;
    t.set_essential(coord, false);
    // Until the coordinator closes (or is lost), so that nothing is cut short.
    let _ = t.link_endings(Duration::from_secs_f64(setup.recv_timeout_s));
    if result.is_err() {
        close_failed(&t, since);
    } else {
        t.close(Duration::from_secs(2));
    }
    result.map(|_| ())
}

/// The messages queued while this worker rendered, or an error if the
/// coordinator gave the frame up meanwhile (e.g. while this process was
/// stopped past the heartbeat deadline): it is essential during the frame,
/// so its `Goodbye`, like any lost link, is an error here. The frame is
/// then dropped and the session ends failed, not "done" with layers that
/// nobody reads (its peers' phase-2 messages may well be queued already).
fn queued_unless_given_up(t: &TcpTransport) -> anyhow::Result<Vec<crate::net::Envelope>> {
    let mut queued = Vec::new();
    loop {
        match t.try_recv() {
            Ok(Some(e)) => queued.push(e),
            Ok(None) => return Ok(queued),
            Err(e) => anyhow::bail!("the frame was given up while this worker rendered: {e}"),
        }
    }
}

/// A grid worker's frame composited worker to worker: join the mesh of
/// peers (dial lower ranks, accept higher ones), render, send the stats to
/// the coordinator, run this rank's part of the schedule over the mesh
/// ([`crate::cluster::remote::phase2::run_partial`] with a [`LayerRank`]), send the log. Any
/// error is reported to the coordinator (`Failed`) before the links close.
#[allow(clippy::too_many_arguments)]
fn serve_p2p(
    stream: TcpStream,
    kept: &mut GridWorkerCache,
    mesh: Mesh,
    setup: &GridSetup,
    bytes: &[u8],
    coord: NodeId,
    name: &str,
    hooks: Hooks,
) -> anyhow::Result<()> {
    let codec = Codec::with_limit(setup.max_message_bytes);
    let t = mesh.transport(
        setup.rank,
        setup.nodes,
        &setup.peers,
        setup.session_id,
        coord,
        name.to_string(),
        stream,
        codec,
    )?;
    t.set_essential(coord, true);
    let since = std::time::Instant::now();
    let r = frame_p2p(&t, kept, setup, bytes, coord, hooks, since);
    match r {
        Ok(()) => {
            t.close(Duration::from_secs(10));
            Ok(())
        }
        Err(e) => {
            let why = format!("grid node {}: {e:#}", setup.rank);
            report_failure(&t, coord, &codec, &why, since);
            close_failed(&t, since);
            anyhow::bail!(why)
        }
    }
}

/// Render, stats to the coordinator, phase 2 over `t`, the log (`since`:
/// when the frame began, for the stall checks).
fn frame_p2p(
    t: &TcpTransport,
    kept: &mut GridWorkerCache,
    setup: &GridSetup,
    bytes: &[u8],
    coord: NodeId,
    hooks: Hooks,
    since: std::time::Instant,
) -> anyhow::Result<()> {
    let codec = Codec::with_limit(setup.max_message_bytes);
    if hooks.kill_after_chunks.is_some() {
        kill_self("while rendering its bricks (--test-kill-after-chunks)");
    }
    let (stats, layers) = render(setup, bytes, kept)?;
    let early = queued_unless_given_up(t)?;
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
    let strategy = setup.compositor.build();
    let sched = strategy.schedule(
        setup.nodes as usize,
        screen(scene.image.width, scene.image.height),
    );
    sched.validate().map_err(|e| anyhow::anyhow!(e))?;
    let lc = setup.codec.build();
    if hooks.kill_in_phase2 {
        // The stats above go out on the link's writer task; give it a
        // moment (the message is small) so that the coordinator has them
        // and the loss is one in phase 2, not while rendering.
        std::thread::sleep(Duration::from_millis(300));
        kill_self("at the start of phase 2 (--test-kill-in-phase2)");
    }
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
        early,
        Duration::from_secs_f64(setup.recv_timeout_s),
    )?;
    // The coordinator waits for every rank's log before it ends the frame:
    // its `Goodbye` before ours went out means it gave the frame up.
    queued_unless_given_up(t)?;
    given_up_while_stopped(t, since)?;
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
    let lc = setup.codec.build();
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
