//! Phase 1 of a cluster run: `N` [`NodeActor`]s and a [`ManagerActor`]
//! (rank `N`) under either driver — the discrete-event simulator (virtual
//! clock, deterministic) or real threads over channels (wall clock, compute
//! charged as the real work done, [`ComputeMode::Skip`]).

use std::time::Instant;

use crate::manager::{ManagerActor, ManagerConfig, ShardActor};
use crate::net::{
    run_threads, Action, Actor, ChannelNetwork, Codec, ComputeMode, Event, NetworkModel,
    SimOptions, SimTrace, Simulation, TrafficStats, WallOptions,
};
use crate::node::shard_map::ShardMap;
use crate::node::{
    CostProfile, DataMode, NodeActor, NodeConfig, NodeOptions, NodePolicy, NodeRenderer, Placement,
    Replica, WorkUnit,
};
use crate::render::cell::PreparedTf;
use crate::render::RenderInput;

/// Which clock drives the run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ClockKind {
    /// Discrete-event simulation on a virtual clock: deterministic, modelled
    /// compute (cost profile) and network (network model).
    Virtual,
    /// Real threads over in-process channels: wall-clock times, compute
    /// charged as the real work done.
    Wall,
}

/// The protocol knobs of phase 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Phase1Config {
    /// Nodes.
    pub nodes: usize,
    /// Node renderer options (ERT, order, partial composition).
    pub node: NodeOptions,
    /// Weak ERT sharing through the manager (`--sharing manager`).
    pub share: bool,
    /// Weak ERT sharing without the manager (`--sharing overlap`): each node
    /// sends its table straight to the nodes whose initial screen footprints
    /// ([`Placement::footprints`]) overlap its own. Ignored when `share` is set.
    pub overlap: bool,
    /// Dynamic load balancing.
    pub dlb: bool,
    /// Where the cells live: replicated (every node holds the mesh; DLB and
    /// help move ids) or partitioned (cells move with their vertices).
    pub data: DataMode,
    /// Pacing, work giving and share window of every node.
    pub policy: NodePolicy,
    /// Global front-to-back schedule ([`crate::node::schedule`], with
    /// replicated data and sharing): depth waves of leaves dealt evenly
    /// over the nodes, computed by every node itself; 0 or 1: off (each
    /// node scans its part).
    pub schedule_waves: usize,
    /// Global schedule: runs only with at least this many cells per node
    /// on average (0: whenever `schedule_waves > 1`; the default's rule,
    /// [`crate::node::schedule::MIN_CELLS_PER_NODE`], keeps it off where
    /// keying the leaves would cost more than it saves).
    pub schedule_min_cells: usize,
    /// Global schedule: applied only when the placement's parts are
    /// stacked along the view by at least this
    /// ([`crate::node::schedule::stacking`]; 0: always).
    pub schedule_min_stacking: f64,
    /// Global schedule: cells per leaf (each node's placement part cut by
    /// bisection into leaves of about this many cells; the unit dealt).
    pub schedule_leaf_cells: usize,
    /// Manager shards `K` for per-pixel sharing (`--manager-shards`):
    /// `None`, the default for the node count
    /// ([`ShardMap::default_count`]: 1 up to 16 nodes). Only per-pixel
    /// sharing is sharded; other modes run one manager.
    pub manager_shards: Option<usize>,
    /// Clock.
    pub clock: ClockKind,
    /// Record the timeline.
    pub record_trace: bool,
}

/// What phase 1 produced.
#[derive(Debug)]
pub struct Phase1 {
    /// The nodes after the run (renderers with their lists, stats).
    pub nodes: Vec<NodeActor>,
    /// The manager after the run.
    pub manager: ManagerActor,
    /// End of phase 1: the last node's `Finish` (seconds, virtual or wall).
    pub end_s: f64,
    /// Per rank, when it stopped.
    pub stopped_at: Vec<Option<f64>>,
    /// The timeline (ranks `0..N` nodes, `N` the manager).
    pub trace: SimTrace,
    /// Traffic per kind.
    pub traffic: TrafficStats,
    /// Host seconds the run took.
    pub host_s: f64,
}

enum Rank<'a> {
    Node(&'a mut NodeActor),
    Manager(&'a mut ManagerActor),
    Shard(&'a mut ShardActor),
}

impl Actor for Rank<'_> {
    fn handle(&mut self, now: f64, event: Event) -> Vec<Action> {
        match self {
            Rank::Node(a) => a.handle(now, event),
            Rank::Manager(a) => a.handle(now, event),
            Rank::Shard(a) => a.handle(now, event),
        }
    }
}

/// What a mesh frame's nodes hold that does not depend on the camera,
/// kept across the frames of a series: each placement part's cells with
/// their vertices (encoded and decoded once, as on the wire) and, with
/// replicated data, the shared replica. A frame whose parts differ from the
/// placement's (a global wave schedule, which depends on the view) builds
/// its units anew.
#[derive(Debug, Clone, Default)]
pub struct NodeData {
    /// Per placement part, its cells and their vertex data.
    pub units: Vec<WorkUnit>,
    /// With replicated data: the mesh every node reads.
    pub replica: Option<std::sync::Arc<Replica>>,
}

impl NodeData {
    /// Builds the units of `placement`'s parts (in parallel).
    pub fn new(
        input: &RenderInput,
        placement: &Placement,
        cfg: &Phase1Config,
    ) -> anyhow::Result<NodeData> {
        use rayon::prelude::*;
        let units = placement
            .parts
            .par_iter()
            .map(|part| unit_of(input, part))
            .collect::<anyhow::Result<Vec<_>>>()?;
        let replica = (cfg.data == DataMode::Replicated)
            .then(|| std::sync::Arc::new(Replica::new(input.mesh.clone(), &input.s_norm)));
        Ok(NodeData { units, replica })
    }
}

/// A part's cells with their vertices, through the wire form.
fn unit_of(input: &RenderInput, part: &[u32]) -> anyhow::Result<WorkUnit> {
    let unit = WorkUnit::from_mesh(&input.mesh, &input.s_norm, part);
    Ok(WorkUnit::decode(&unit.encode())?)
}

/// The nodes of a frame: each node's cells (with their vertex data, encoded
/// and decoded, as on the wire), each loaded into its renderer; with replicated
/// data every node also reads the one shared mesh (its memory and one-time
/// cost per dataset, reported apart: [`crate::node::replica`]).
pub fn build_nodes(
    input: &RenderInput,
    placement: &Placement,
    cfg: &Phase1Config,
    profile: &CostProfile,
    codec: Codec,
) -> anyhow::Result<Vec<NodeActor>> {
    build_nodes_from(input, placement, &NodeData::default(), cfg, profile, codec)
}

/// [`build_nodes`] over node data built before (kept across a series).
pub fn build_nodes_from(
    input: &RenderInput,
    placement: &Placement,
    data: &NodeData,
    cfg: &Phase1Config,
    profile: &CostProfile,
    codec: Codec,
) -> anyhow::Result<Vec<NodeActor>> {
    let view = input.scene.view();
    let tf = PreparedTf::new(&input.scene.transfer);
    let n = cfg.nodes;
    let overlap = cfg.overlap && !cfg.share && cfg.node.ert.enabled();
    let pairwise = if overlap {
        placement.footprints(input).pairwise
    } else {
        Vec::new()
    };
    let replica = match (&data.replica, cfg.data) {
        (Some(r), DataMode::Replicated) => Some(r.clone()),
        (None, DataMode::Replicated) => Some(std::sync::Arc::new(Replica::new(
            input.mesh.clone(),
            &input.s_norm,
        ))),
        _ => None,
    };
    let waves = (effective_waves(cfg, input.mesh.tets.len()) > 1).then(|| {
        wave_schedule(
            input,
            placement,
            cfg.schedule_waves,
            cfg.schedule_leaf_cells,
            cfg.schedule_min_stacking,
        )
    });
    let applied = waves.as_ref().is_some_and(|w| w.1);
    let waves = waves.map(|w| w.0);
    let (parts, kept) = match &waves {
        Some(w) if applied => (&w.parts, false),
        _ => (&placement.parts, data.units.len() == placement.parts.len()),
    };
    parts
        .iter()
        .enumerate()
        .map(|(k, part)| {
            crate::base::cancel::checkpoint();
            let mut r = NodeRenderer::new(view, tf.clone(), cfg.node);
            if let Some(rep) = &replica {
                r.set_replica(rep.clone());
            }
            if cfg.share {
                r.enable_level_sharing();
                r.enable_pixel_sharing(depth_quant(input));
            }
            if kept {
                r.add_work(&data.units[k])?;
            } else {
                r.add_work(&unit_of(input, part)?)?;
            }
            let nc = NodeConfig {
                rank: k,
                manager: n,
                share: cfg.share && cfg.node.ert.enabled(),
                dlb: cfg.dlb,
                policy: cfg.policy,
            };
            let mut a = NodeActor::new(nc, r, *profile, codec, part.len() as u64);
            if let Some(w) = &waves {
                a.set_schedule(w, applied);
            }
            if overlap {
                a.set_peers(
                    (0..n)
                        .filter(|&b| b != k && pairwise[k].get(b).is_some_and(|&p| p > 0))
                        .collect(),
                );
            }
            Ok(a)
        })
        .collect()
}

/// The waves of the global schedule a run of `cfg` over `cells` cells uses:
/// `cfg.schedule_waves` with sharing through the manager, replicated data
/// and at least `schedule_min_cells` cells per node; else 0 (off).
pub fn effective_waves(cfg: &Phase1Config, cells: usize) -> usize {
    let on = cfg.schedule_waves > 1
        && cfg.share
        && cfg.node.ert.enabled()
        && cfg.data == DataMode::Replicated
        && cells >= cfg.schedule_min_cells.saturating_mul(cfg.nodes.max(1));
    if on {
        cfg.schedule_waves
    } else {
        0
    }
}

/// The global front-to-back schedule of [`crate::node::schedule`] over
/// `placement`, as every node computes it: first the parts' stacking along
/// the view from [`crate::node::schedule::PROBES_PER_NODE`] coarse leaves
/// per part; below `min_stacking` the placement stays (returned with
/// `false`, only the probes keyed); else leaves of about `leaf_cells` cells
/// dealt in `waves` waves. Leaves are view-independent (once per dataset);
/// their keys (centre's camera `z` and pixel) are per frame.
fn wave_schedule(
    input: &RenderInput,
    placement: &Placement,
    waves: usize,
    leaf_cells: usize,
    min_stacking: f64,
) -> (crate::node::schedule::WaveSchedule, bool) {
    use crate::node::schedule::{leaf_waves, stacking, Leaves, WaveSchedule, PROBES_PER_NODE};
    let view = input.scene.view();
    let n = placement.parts.len();
    let c = crate::node::placement::centroids(&input.mesh);
    let keys = |leaves: &Leaves| -> (Vec<f64>, Vec<[f64; 2]>) {
        let cam: Vec<[f64; 3]> = leaves.centre.iter().map(|&p| view.to_camera(p)).collect();
        let depth = cam.iter().map(|q| q[2]).collect();
        let screen = cam
            .iter()
            .map(|&q| view.camera_to_pixel(q).unwrap_or([q[0], -q[1]]))
            .collect();
        (depth, screen)
    };
    let per_part = placement.parts.iter().map(Vec::len).max().unwrap_or(0);
    let probes = Leaves::new(&placement.parts, &c, per_part.div_ceil(PROBES_PER_NODE));
    let (pd, _) = keys(&probes);
    let st = stacking(&probes.owner, &pd, n);
    if st < min_stacking {
        let none = WaveSchedule {
            parts: placement.parts.clone(),
            given: vec![0; n],
            received: vec![0; n],
            keyed: probes.len() as u64,
            stacking: st,
        };
        return (none, false);
    }
    let leaves = Leaves::new(&placement.parts, &c, leaf_cells);
    let (depth, screen) = keys(&leaves);
    let mut w = leaf_waves(&leaves, &depth, &screen, n, waves);
    w.keyed += probes.len() as u64;
    w.stacking = st;
    (w, true)
}

/// Depth codes for per-pixel sharing over the frame's depth range: the
/// vertices' smallest and largest depth (screen depth, or distance from the
/// eye in perspective: convex, so no point of a cell is farther than its
/// farthest vertex; nearer points get code 0, which rounds them up).
fn depth_quant(input: &RenderInput) -> crate::node::pixel_share::DepthQuant {
    let [z0, z1] = depth_range(input);
    crate::node::pixel_share::DepthQuant::new(z0, z1)
}

/// The frame's depth range `[z0, z1]` for per-pixel sharing's depth codes
/// (see `depth_quant`), padded a little.
pub fn depth_range(input: &RenderInput) -> [f32; 2] {
    padded_depths(depth_extent(&input.scene.view(), &input.mesh.points))
}

/// The smallest and largest depth of `points` in `view` (distance from the
/// eye in perspective, camera `z` in orthographic), `(inf, -inf)` if none.
pub fn depth_extent(view: &crate::scene::View, points: &[[f64; 3]]) -> (f64, f64) {
    let persp = matches!(
        view.projection,
        crate::scene::Projection::Perspective { .. }
    );
    points
        .iter()
        .map(|&p| {
            let c = view.to_camera(p);
            if persp {
                (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
            } else {
                c[2]
            }
        })
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), z| {
            (a.min(z), b.max(z))
        })
}

/// [`depth_range`] of an extent (the union of pieces' [`depth_extent`]s).
pub fn padded_depths((lo, hi): (f64, f64)) -> [f32; 2] {
    // Widen by a relative epsilon: f32 segment depths may round past the
    // f64 extremes.
    let pad = 1e-4 * (hi - lo).abs().max(1.0);
    [(lo - pad) as f32, (hi + pad) as f32]
}

/// The manager shards of a run: `cfg.manager_shards` (or the default for
/// the node count) over the screen when the nodes share per-pixel levels;
/// one shard (the manager) otherwise. Errors if the count given is out of
/// range (`K < 1` or more than the screen's tiles), or if it asks for more
/// than one shard of a run without per-pixel sharing.
pub fn shard_map(
    cfg: &Phase1Config,
    pixels: Option<(u32, u32, usize)>,
) -> anyhow::Result<ShardMap> {
    match (pixels, cfg.manager_shards) {
        (Some((w, h, _)), k) => {
            let k = k.unwrap_or_else(|| ShardMap::default_count(cfg.nodes, ShardMap::tiles(w, h)));
            ShardMap::new(w, h, k).map_err(|e| anyhow::anyhow!(e))
        }
        (None, Some(k)) if k != 1 => anyhow::bail!(
            "--manager-shards {k}: only per-pixel sharing (--share with the pyramid \
             structure, not --paper or --ert-structure flat) is sharded"
        ),
        (None, _) => Ok(ShardMap::single()),
    }
}

/// Runs phase 1 over `nodes` (from [`build_nodes`]).
pub fn run(
    mut nodes: Vec<NodeActor>,
    cfg: &Phase1Config,
    model: &NetworkModel,
    profile: &CostProfile,
    codec: Codec,
) -> anyhow::Result<Phase1> {
    let n = nodes.len();
    anyhow::ensure!(n > 0, "a cluster needs at least one node");
    let (nx, ny) = nodes[0].renderer().table_dims();
    let mcfg = ManagerConfig {
        nodes: n,
        table_dims: (nx as u16, ny as u16),
        dlb: cfg.dlb,
        min_grant: cfg.policy.min_grant as u64,
        levels: if cfg.share {
            nodes[0].renderer().level_grid()
        } else {
            None
        },
        pixels: if cfg.share {
            nodes[0].renderer().pixel_share_shape()
        } else {
            None
        },
        help_gap: match nodes[0].renderer().depth_span() {
            Some(span) if cfg.share && cfg.dlb && cfg.policy.help_gap > 0.0 => {
                Some(cfg.policy.help_gap * span)
            }
            _ => None,
        },
        release: nodes[0]
            .renderer()
            .release_blocks()
            .filter(|_| cfg.share)
            .map(|b| (b.bw, b.bh)),
    };
    let initial = nodes
        .iter()
        .map(|a| a.renderer().remaining() as u64)
        .collect();
    let map = shard_map(cfg, mcfg.pixels)?;
    let mut manager = ManagerActor::new(mcfg, initial, *profile, codec);
    manager.set_shards(map);
    for a in nodes.iter_mut() {
        a.set_manager_shards(map);
    }
    let mut shards: Vec<ShardActor> = match mcfg.pixels {
        Some(shape) => (1..map.count())
            .map(|s| ShardActor::new(s, map, n, shape, *profile, codec))
            .collect(),
        None => Vec::new(),
    };
    let t0 = Instant::now();
    let (stopped_at, trace, traffic) = {
        let mut ranks: Vec<Rank> = nodes.iter_mut().map(Rank::Node).collect();
        ranks.push(Rank::Manager(&mut manager));
        ranks.extend(shards.iter_mut().map(Rank::Shard));
        drive(ranks, cfg.clock, model, cfg.record_trace, "phase 1")?
    };
    let host_s = t0.elapsed().as_secs_f64();
    if let Some(e) = &manager.stats().error {
        anyhow::bail!("phase 1 failed at the manager: {e}");
    }
    if let Some(e) = shards.iter().find_map(|s| s.stats().error.as_ref()) {
        anyhow::bail!("phase 1 failed at {e}");
    }
    manager.record_shards(shards.iter().map(|s| s.stats()));
    if let Some((k, e)) = nodes
        .iter()
        .enumerate()
        .find_map(|(k, a)| a.stats().error.as_ref().map(|e| (k, e)))
    {
        anyhow::bail!("phase 1 failed at node {k}: {e}");
    }
    let end_s = stopped_at[..n]
        .iter()
        .flatten()
        .fold(0.0f64, |a, &b| a.max(b));
    Ok(Phase1 {
        nodes,
        manager,
        end_s,
        stopped_at,
        trace,
        traffic,
        host_s,
    })
}

/// A rank under the simulator that stops a cancelled job (Ctrl-C in the
/// Python module) at a checkpoint before each event it handles.
struct Cancellable<A>(A);

impl<A: Actor> Actor for Cancellable<A> {
    fn handle(&mut self, now: f64, event: Event) -> Vec<Action> {
        crate::base::cancel::checkpoint();
        self.0.handle(now, event)
    }
}

/// The one phase-1 driver, for any node kind: runs `ranks` under the
/// discrete-event simulator (virtual clock) or on threads over channels
/// (wall clock, compute charged as the real work done); returns per rank
/// when it stopped, the timeline and the traffic.
pub fn drive<A: Actor + Send>(
    ranks: Vec<A>,
    clock: ClockKind,
    model: &NetworkModel,
    record_trace: bool,
    what: &str,
) -> anyhow::Result<(Vec<Option<f64>>, SimTrace, TrafficStats)> {
    let n = ranks.len();
    Ok(match clock {
        ClockKind::Virtual => {
            let ranks: Vec<_> = ranks.into_iter().map(Cancellable).collect();
            let rep = Simulation::new(model.clone(), ranks)
                .with_options(SimOptions {
                    record_trace,
                    ..Default::default()
                })
                .run()?;
            anyhow::ensure!(
                rep.unfinished().is_empty(),
                "{what} deadlocked: ranks {:?} never finished",
                rep.unfinished()
            );
            (rep.stopped_at, rep.trace, rep.traffic)
        }
        ClockKind::Wall => {
            let transports = ChannelNetwork::new(n);
            let rep = run_threads(
                &transports,
                ranks,
                WallOptions {
                    compute: ComputeMode::Skip,
                    ..Default::default()
                },
            )?;
            // A rank's thread cannot unwind alone (the others would wait
            // for it): a cancelled wall-clock run stops here.
            crate::base::cancel::checkpoint();
            (
                rep.stopped_at.into_iter().map(Some).collect(),
                rep.trace,
                rep.traffic,
            )
        }
    })
}
