//! One node's frame on a worker, transport independent ([`run_node`]):
//! build the node from the set-up, phase 1 with the thread driver loop,
//! the result, phase 2 worker to worker, with the test hooks that kill the
//! process mid-frame ([`Hooks`]).

use std::path::Path;
use std::time::Duration;

use crate::cluster::remote::guard::{
    close_failed, given_up_while_stopped, report_failure, SessionGuard,
};
use crate::cluster::remote::hooks::{kill_self, Hooks};
use crate::cluster::remote::session::{NodeResult, Session, WorkerSetup};
use crate::cluster::report::NodeRaw;
use crate::net::{
    run_actor, Codec, ComputeMode, Counter, MessageKind, NodeId, RemoteTransport, TrafficStats,
    WallClock, WallOptions,
};
use crate::node::{NodeActor, NodeConfig, NodeRenderer, WorkUnit};
use crate::render::cell::PreparedTf;
use crate::scene::Scene;

/// The node actor, counting its chunks (`Start` and every `Wake`) for
/// [`super::Worker::kill_after_chunks`].
struct Chunks<'a> {
    node: &'a mut NodeActor,
    kill_after: Option<u64>,
    seen: u64,
}

impl crate::net::Actor for Chunks<'_> {
    fn handle(&mut self, now: f64, event: crate::net::Event) -> Vec<crate::net::Action> {
        if matches!(event, crate::net::Event::Start | crate::net::Event::Wake(_)) {
            if self.kill_after == Some(self.seen) {
                kill_self(&format!(
                    "after {} chunks (--test-kill-after-chunks)",
                    self.seen
                ));
            }
            self.seen += 1;
        }
        self.node.handle(now, event)
    }
}

/// What a worker's node is built from, kept across the frames of a
/// session: its cells, decoded and validated once (sent by the
/// coordinator), or its pieces, read once (a unit a piece). Each frame
/// adds them to a fresh node for its camera and transfer function.
#[derive(Debug, Default)]
pub struct Held {
    /// The SHA-256 of the cells' bytes they came from (zero for pieces).
    pub key: [u8; 32],
    /// The units.
    pub units: Vec<WorkUnit>,
}

impl Held {
    /// The data of `setup`: its pieces read, or `cells` decoded and
    /// validated.
    pub fn load(setup: &WorkerSetup, cells: &[u8]) -> anyhow::Result<Held> {
        let units = match &setup.pieces {
            Some(src) => crate::cluster::remote::pieces::read_units(src)?,
            None => {
                let unit =
                    WorkUnit::decode(cells).map_err(|e| anyhow::anyhow!("the cells: {e}"))?;
                unit.validate()
                    .map_err(|e| anyhow::anyhow!("the cells: {e}"))?;
                vec![unit]
            }
        };
        Ok(Held {
            key: setup.cells_sha256,
            units,
        })
    }
}

/// One node's frame over `t` (rank `setup.rank`; the coordinator is rank
/// `setup.nodes`), once the set-up and the cells are in and the links to
/// the peers are up: build the node (from `held`, loaded from the set-up
/// and `cells` first when it is `None`), `Ready`, wait (at most `go_wait`)
/// for `Go`, phase 1, the result, phase 2, the log. On any error the
/// coordinator is told why (`Failed`) and the links close; on success
/// they stay up for the session's next frame (the caller closes them).
/// Transport independent: TCP and MPI workers both end here.
pub fn run_node<T: RemoteTransport>(
    t: &T,
    setup: &WorkerSetup,
    cells: &[u8],
    held: &mut Option<Held>,
    go_wait: Duration,
    hooks: Hooks,
) -> anyhow::Result<()> {
    let since = std::time::Instant::now();
    let coord = NodeId(setup.nodes);
    let codec = Codec::with_limit(setup.max_message_bytes);
    let d = go_wait;
    t.set_essential(coord, true);
    // Built after the mesh (peers wait on our accept meanwhile) and
    // with the links up (heartbeats flow while the cells are sorted).
    let built = match held {
        Some(h) => Ok(h),
        None => Held::load(setup, cells).map(|h| held.insert(h)),
    }
    .and_then(|h| build_node(setup, h));
    let mut actor = match built {
        Ok(a) => a,
        Err(e) => {
            let why = format!("node {}: {e:#}", setup.rank);
            report_failure(t, coord, &codec, &why, since);
            t.close(Duration::from_secs(2));
            return Err(e);
        }
    };
    let ready = Session::Ready {
        remaining: actor.renderer().remaining() as u64,
    };
    t.send(coord, MessageKind::Session, codec.encode(&ready)?)?;
    // Wait for Go; messages from peers that started earlier are kept.
    let early = SessionGuard::wait_go(t, coord, codec, d)?;
    crate::cluster::remote::hooks::progress(&format!("node {}: phase 1 started", setup.rank));
    if hooks.kill_at_frame == Some(hooks.frame) {
        kill_self(&format!(
            "at frame {} of its session (--test-kill-at-frame)",
            hooks.frame
        ));
    }
    let clock = WallClock::start();
    let timeout = Duration::from_secs_f64(setup.recv_timeout_s);
    let wire0 = t.stats();
    let run = run_actor(
        &early,
        Chunks {
            node: &mut actor,
            kill_after: hooks.kill_after_chunks,
            seen: 0,
        },
        clock,
        WallOptions {
            compute: ComputeMode::Skip,
            recv_timeout: timeout,
        },
    );
    let (stop, trace, traffic) = match run {
        Ok(x) => x,
        Err(e) => {
            // Tell the coordinator why (a lost peer, most likely: named,
            // so that it is the one dropped).
            let why = format!("node {} in phase 1: {e}", setup.rank);
            report_failure(t, coord, &codec, &why, since);
            close_failed(t, since);
            anyhow::bail!(why);
        }
    };
    if let Some(e) = &actor.stats().error {
        crate::cluster::remote::hooks::say(&format!("node {} failed: {e}", setup.rank));
    }
    let mut wire = t.stats();
    wire.payload = traffic.clone();
    wire.wire_bytes_sent -= wire0.wire_bytes_sent;
    wire.wire_bytes_recv -= wire0.wire_bytes_recv;
    let scene = parse_scene(setup)?;
    let lists = worker_lists(&actor, setup, (scene.image.width, scene.image.height));
    let result = NodeResult {
        raw: NodeRaw::from_actor(&actor).with_process_peak_rss(),
        stopped_at: stop,
        trace,
        traffic,
        wire,
    };
    if let Err(e) = given_up_while_stopped(t, since) {
        close_failed(t, since);
        return Err(e.context(format!("node {} at the end of phase 1", setup.rank)));
    }
    t.send(
        coord,
        MessageKind::Session,
        codec.encode(&Session::Result(Box::new(result)))?,
    )?;
    // Phase 2, once every node is done with phase 1.
    let wire0 = t.stats();
    let r = wait_composite(t, coord, codec, timeout).and_then(|early| {
        if hooks.kill_in_phase2 {
            kill_self("at the start of phase 2 (--test-kill-in-phase2)");
        }
        let log = phase2(t, setup, &scene, lists, early, timeout)?;
        let mut wire = t.stats();
        wire.wire_bytes_sent -= wire0.wire_bytes_sent;
        wire.wire_bytes_recv -= wire0.wire_bytes_recv;
        wire.payload = diff_traffic(&wire.payload, &wire0.payload);
        given_up_while_stopped(t, since)?;
        Ok((log, wire))
    });
    match r {
        Ok(done) => {
            t.send(
                coord,
                MessageKind::Session,
                codec.encode(&Session::Phase2Done(Box::new(done)))?,
            )?;
            Ok(())
        }
        Err(e) => {
            let why = format!("node {} in phase 2: {e:#}", setup.rank);
            report_failure(t, coord, &codec, &why, since);
            close_failed(t, since);
            anyhow::bail!(why)
        }
    }
}

/// Waits for the coordinator's `Composite`; returns the phase-2 messages of
/// peers that started first (late phase-1 messages are dropped).
fn wait_composite<T: RemoteTransport>(
    t: &T,
    coord: NodeId,
    codec: Codec,
    wait: Duration,
) -> anyhow::Result<Vec<crate::net::Envelope>> {
    let mut early = Vec::new();
    loop {
        let e = t
            .recv_timeout(wait)?
            .ok_or_else(|| anyhow::anyhow!("no word from the coordinator within {wait:?}"))?;
        if e.kind == MessageKind::Segments {
            early.push(e);
        } else if e.kind == MessageKind::Session {
            match codec.decode::<Session>(&e.payload) {
                Ok(Session::Composite) if e.from == coord => return Ok(early),
                Ok(Session::Failed(why)) => {
                    anyhow::bail!("{} failed: {why}", t.peer_name(e.from))
                }
                _ => anyhow::bail!("{} sent a session message out of turn", t.peer_name(e.from)),
            }
        }
    }
}

/// This rank's part of phase 2 (see [`crate::cluster::remote::phase2`]).
fn phase2<T: RemoteTransport>(
    t: &T,
    setup: &WorkerSetup,
    scene: &Scene,
    lists: crate::compositor::RegionLists,
    early: Vec<crate::net::Envelope>,
    timeout: Duration,
) -> anyhow::Result<crate::cluster::remote::phase2::RankLog> {
    let strategy = setup.compositor.build();
    let codec = setup.list_codec.build();
    let schedule = strategy.schedule(
        setup.nodes as usize,
        crate::compositor::region::screen(scene.image.width, scene.image.height),
    );
    schedule.validate().map_err(|e| anyhow::anyhow!("{e}"))?;
    crate::cluster::remote::phase2::run_rank(
        t,
        setup.rank as usize,
        NodeId(setup.nodes),
        &schedule,
        codec.as_ref(),
        &crate::cluster::remote::phase2::exec_options(
            setup.node_options().partial_composition,
            scene,
        ),
        lists,
        early,
        timeout,
    )
}

/// `a - b`, per kind (counters only grow).
fn diff_traffic(a: &TrafficStats, b: &TrafficStats) -> TrafficStats {
    let mut out = TrafficStats::default();
    for (k, c) in &a.sent_by_kind {
        let b0 = b.sent_by_kind.get(k).copied().unwrap_or_default();
        out.sent_by_kind.insert(*k, minus(c, &b0));
    }
    for (k, c) in &a.recv_by_kind {
        let b0 = b.recv_by_kind.get(k).copied().unwrap_or_default();
        out.recv_by_kind.insert(*k, minus(c, &b0));
    }
    out
}

fn minus(a: &Counter, b: &Counter) -> Counter {
    Counter {
        messages: a.messages - b.messages,
        bytes: a.bytes - b.bytes,
    }
}

fn parse_scene(setup: &WorkerSetup) -> anyhow::Result<Scene> {
    Scene::parse(&setup.scene_toml, Path::new("(scene from the coordinator)"))
        .map_err(|e| anyhow::anyhow!("{e}"))
}

/// The node a set-up describes, with its cells or pieces (`held`).
pub fn build_node(setup: &WorkerSetup, held: &Held) -> anyhow::Result<NodeActor> {
    let scene = parse_scene(setup)?;
    let opts = setup.node_options();
    let mut r = NodeRenderer::new(scene.view(), PreparedTf::new(&scene.transfer), opts);
    if setup.share {
        r.enable_level_sharing();
        let [z0, z1] = setup.depth_range;
        r.enable_pixel_sharing(crate::node::pixel_share::DepthQuant::new(z0, z1));
    }
    let added = crate::cluster::remote::pieces::add_units(&held.units, &mut r);
    let cells_initial = match &setup.pieces {
        Some(_) => added,
        None => setup.cells_initial,
    };
    let nc = NodeConfig {
        rank: setup.rank as usize,
        manager: setup.nodes as usize,
        share: setup.share && opts.ert.enabled(),
        dlb: setup.dlb,
        policy: setup.policy.into(),
    };
    let mut a = NodeActor::new(nc, r, setup.profile, Codec::default(), cells_initial);
    if !setup.overlap_peers.is_empty() {
        a.set_peers(setup.overlap_peers.iter().map(|&p| p as usize).collect());
    }
    Ok(a)
}

/// The node's canonical lists over the whole screen (as
/// [`crate::cluster`] takes them from its nodes).
fn worker_lists(
    actor: &NodeActor,
    setup: &WorkerSetup,
    (w, h): (u32, u32),
) -> crate::compositor::RegionLists {
    let full = crate::base::Rect {
        x0: 0,
        y0: 0,
        x1: w,
        y1: h,
    };
    let opts = setup.node_options();
    let r = actor.renderer();
    if opts.canonical {
        crate::compositor::RegionLists::from_canonical_fn(full, |x, y| r.list(x, y))
    } else {
        crate::compositor::RegionLists::canonical(full, r.lists().lists(), opts.partial_composition)
    }
}
