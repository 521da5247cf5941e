//! The simulated PC cluster: phase 1 (scan conversion with ERT, weak
//! sharing, DLB — [`phase1`]), phase 2 (compositing — [`phase2`]), the run
//! report ([`report`]) and the per-node timeline ([`timeline`]).
//!
//! ```text
//! placement ─► N × NodeActor + ManagerActor ─► DES (virtual) or threads (wall)
//!          ─► per-node lists (canonical) ─► compositor schedule, every message
//!             replayed through the network model ─► image at rank 0 + report
//! ```
//!
//! [`run`] does it all for one configuration. With [`ClusterConfig::baselines`]
//! it also runs the two reference points the report's ratios need: the
//! sequential renderer (one [`crate::node::NodeRenderer`] holding every cell,
//! same ERT mode, same cost model) and the `Base` cluster (same `N`, ERT,
//! sharing and DLB off, phase 1 only).

pub mod frame;
pub mod grid;
pub mod phase1;
pub mod phase2;
pub mod remote;
pub mod report;
pub mod series;
pub mod timeline;

use crate::compositor::ExecOptions;
use crate::image::Image;
use crate::net::{Codec, NetworkModel, SimTrace};
use crate::node::renderer::NodeErt;
use crate::node::{CostProfile, NodeOptions, NodeRenderer, Placement, PlacementMethod, WorkUnit};
use crate::render::cell::PreparedTf;
use crate::render::RenderInput;

pub use frame::FrameData;
pub use phase1::{ClockKind, Phase1, Phase1Config};
pub use report::{ClusterReport, NodeReport};

/// Everything a cluster run needs besides the scene.
#[derive(Debug, Clone)]
pub struct ClusterConfig {
    /// Phase-1 protocol (nodes, ERT, sharing, DLB, chunking, clock).
    pub phase1: Phase1Config,
    /// Initial placement of cells.
    pub placement: PlacementMethod,
    /// Compositing strategy.
    pub compositor: crate::compositor::strategy::Compositing,
    /// List/pixel codec.
    pub codec: crate::compositor::codec::ListCodecKind,
    /// Network model (and its name for the report).
    pub network: NetworkModel,
    /// Name of the network model.
    pub network_name: String,
    /// Compute cost profile.
    pub profile: CostProfile,
    /// Name of the profile.
    pub profile_name: String,
    /// Also run the sequential and Base references (for `share_efficiency`
    /// and `ideal_speedup`).
    pub baselines: bool,
}

/// The outcome of [`run`].
#[derive(Debug)]
pub struct ClusterOutcome {
    /// The final image (rank 0, over the background).
    pub image: Image,
    /// The report.
    pub report: ClusterReport,
    /// The whole timeline: phase 1 (nodes and manager) and phase 2 (nodes),
    /// phase 2 shifted to start at the end of phase 1.
    pub trace: SimTrace,
    /// Per node, the cells it processed in phase 1 (its own and those DLB
    /// gave it; ascending). In-process runs only (empty from worker
    /// transports): a series' coherence starts the next frame from it.
    pub processed: Vec<Vec<u32>>,
}

/// The sequential reference: one node with every cell, same options, no
/// network. Returns `(seconds, cells skipped by ERT)`: modelled seconds on
/// the virtual clock, measured (one thread, this host) on the wall clock, so
/// that the speed-ups compare times of one kind.
pub fn sequential_reference(
    input: &RenderInput,
    opts: NodeOptions,
    profile: &CostProfile,
    clock: ClockKind,
) -> anyhow::Result<(f64, u64)> {
    let mut r = NodeRenderer::new(
        input.scene.view(),
        PreparedTf::new(&input.scene.transfer),
        opts,
    );
    let all: Vec<u32> = (0..input.mesh.tets.len() as u32).collect();
    r.add_work(&WorkUnit::from_mesh(&input.mesh, &input.s_norm, &all))?;
    let t = std::time::Instant::now();
    let ops = r.run_to_end();
    let seconds = match clock {
        ClockKind::Virtual => crate::node::compute_time(&ops, profile),
        ClockKind::Wall => t.elapsed().as_secs_f64(),
    };
    Ok((seconds, ops.cells_skipped_ert))
}

/// Runs one cluster configuration on `input`.
pub fn run(input: &RenderInput, cfg: &ClusterConfig) -> anyhow::Result<ClusterOutcome> {
    let placement = place(input, cfg);
    run_placed(input, cfg, &placement, &phase1::NodeData::default())
}

/// The initial placement of `cfg` for `input`'s camera.
pub fn place(input: &RenderInput, cfg: &ClusterConfig) -> Placement {
    place_on(input, cfg.placement, cfg.phase1.nodes)
}

/// The placement `method` of `input` on `n` nodes: by its camera, or by
/// its pieces ([`PlacementMethod::Pieces`] of a `.pvtu`).
pub fn place_on(input: &RenderInput, method: PlacementMethod, n: usize) -> Placement {
    match (&input.pieces, method) {
        (Some(p), PlacementMethod::Pieces) => crate::node::piece_map::place(&input.mesh, p, n),
        _ => Placement::new(&input.mesh, n, method, Some(&input.scene.view())),
    }
}

/// [`run`] with the placement and the nodes' data given (a series keeps
/// them from frame to frame: [`series`]).
pub fn run_placed(
    input: &RenderInput,
    cfg: &ClusterConfig,
    placement: &Placement,
    data: &phase1::NodeData,
) -> anyhow::Result<ClusterOutcome> {
    let p1 = &cfg.phase1;
    let codec = Codec::default();
    let nodes = phase1::build_nodes_from(input, placement, data, p1, &cfg.profile, codec)?;
    let ph1 = phase1::run(nodes, p1, &cfg.network, &cfg.profile, codec)?;

    // References for the ratios.
    let refs = if cfg.baselines {
        let (seq_s, seq_skipped) = sequential_reference(input, p1.node, &cfg.profile, p1.clock)?;
        let base_cfg = Phase1Config {
            node: NodeOptions {
                ert: NodeErt::OFF,
                ..p1.node
            },
            share: false,
            overlap: false,
            dlb: false,
            manager_shards: None,
            schedule_waves: 0,
            schedule_leaf_cells: 0,
            schedule_min_cells: 0,
            schedule_min_stacking: 0.0,
            // Same kind of time as the run itself (see `sequential_reference`).
            clock: p1.clock,
            record_trace: false,
            ..*p1
        };
        let base_tsc = if base_cfg == *p1 {
            None
        } else {
            let nodes =
                phase1::build_nodes_from(input, placement, data, &base_cfg, &cfg.profile, codec)?;
            let b = phase1::run(nodes, &base_cfg, &cfg.network, &cfg.profile, codec)?;
            Some(
                b.nodes
                    .iter()
                    .map(|a| a.stats().tsc_s)
                    .fold(0.0f64, f64::max),
            )
        };
        Some(report::References {
            seq_s,
            seq_skipped,
            base_tsc_max_s: base_tsc,
        })
    } else {
        None
    };

    let Phase1 {
        nodes,
        manager,
        end_s,
        stopped_at,
        trace: trace1,
        traffic: traffic1,
        host_s,
    } = ph1;
    let mut node_stats = Vec::with_capacity(nodes.len());
    let mut lists = Vec::with_capacity(nodes.len());
    let mut processed = Vec::with_capacity(nodes.len());
    let vertices = placement.vertex_counts(&input.mesh);
    for (a, &v) in nodes.iter().zip(&vertices) {
        node_stats.push(report::NodeRaw::from_actor(a).with_vertices_initial(v));
    }
    for a in nodes {
        lists.push(node_lists(a.renderer(), input, p1.node));
        let mut cells: Vec<u32> = a.renderer().processed_cells().collect();
        cells.sort_unstable();
        processed.push(cells);
    }
    let mut out = finish(
        input,
        cfg,
        Phase1Parts {
            nodes: node_stats,
            lists,
            manager: manager.stats().clone(),
            end_s,
            stopped_at,
            trace: trace1,
            traffic: traffic1,
            host_s,
        },
        refs,
    )?;
    out.processed = processed;
    Ok(out)
}

/// A node's lists over the whole screen in canonical form, as phase 2
/// takes them (copied if the node kept them canonical already).
pub fn node_lists(
    r: &NodeRenderer,
    input: &RenderInput,
    opts: NodeOptions,
) -> crate::compositor::RegionLists {
    let full = crate::base::Rect {
        x0: 0,
        y0: 0,
        x1: input.scene.image.width,
        y1: input.scene.image.height,
    };
    if opts.canonical {
        crate::compositor::RegionLists::from_canonical_fn(full, |x, y| r.list(x, y))
    } else {
        crate::compositor::RegionLists::canonical(full, r.lists().lists(), opts.partial_composition)
    }
}

/// What phase 1 left for phase 2 and the report, whichever driver ran it.
#[derive(Debug)]
pub struct Phase1Parts {
    /// Per node, its numbers.
    pub nodes: Vec<report::NodeRaw>,
    /// Per node, its canonical lists over the whole screen.
    pub lists: Vec<crate::compositor::RegionLists>,
    /// The manager's statistics.
    pub manager: crate::manager::ManagerStats,
    /// End of phase 1 (seconds).
    pub end_s: f64,
    /// Per rank, when it stopped.
    pub stopped_at: Vec<Option<f64>>,
    /// The phase-1 timeline.
    pub trace: SimTrace,
    /// Phase-1 traffic.
    pub traffic: crate::net::TrafficStats,
    /// Host seconds of phase 1.
    pub host_s: f64,
}

/// Phase 2 and the report over the lists of phase 1.
pub fn finish(
    input: &RenderInput,
    cfg: &ClusterConfig,
    mut p: Phase1Parts,
    refs: Option<report::References>,
) -> anyhow::Result<ClusterOutcome> {
    let p1 = &cfg.phase1;
    let strategy = cfg.compositor.build();
    let list_codec = cfg.codec.build();
    let partial = p1.node.partial_composition;
    let t2 = std::time::Instant::now();
    let ph2 = phase2::run(
        strategy.as_ref(),
        list_codec.as_ref(),
        std::mem::take(&mut p.lists),
        ExecOptions {
            partial,
            background: input.scene.image.background.map(|c| c as f32),
            ..Default::default()
        },
        &cfg.profile,
        &cfg.network,
        p1.record_trace,
    )?;
    finish_with(
        FrameData::Mesh(input),
        cfg,
        p,
        refs,
        ph2,
        t2.elapsed().as_secs_f64(),
    )
}

/// The report over phase 1's parts (their `lists` unused) and a phase 2
/// that already ran (`host2_s` host seconds), e.g. worker to worker.
pub fn finish_with(
    data: FrameData<'_>,
    cfg: &ClusterConfig,
    p: Phase1Parts,
    refs: Option<report::References>,
    ph2: phase2::Phase2,
    host2_s: f64,
) -> anyhow::Result<ClusterOutcome> {
    let p1 = &cfg.phase1;
    let Phase1Parts {
        nodes: node_stats,
        lists: _,
        manager,
        end_s,
        stopped_at,
        trace: trace1,
        traffic: traffic1,
        host_s,
    } = p;
    let mut trace = trace1;
    if p1.record_trace && p1.clock == ClockKind::Virtual {
        for mut e in ph2.sim.trace.events.iter().cloned() {
            e.start += end_s;
            e.end += end_s;
            trace.events.push(e);
        }
    } else if p1.record_trace {
        // Wall clock: one clock per timeline. Phase 2 ran on this host, all
        // nodes on one thread, so each node gets the host phase-2 window
        // (not the modelled replay, which would mix clocks).
        for k in 0..p1.nodes {
            trace.events.push(crate::net::TraceEvent {
                node: crate::net::NodeId::from(k),
                start: end_s,
                end: end_s + host2_s,
                kind: crate::net::TraceKind::Composite,
                bytes: 0,
                peer: None,
                message: None,
            });
        }
    }
    let report = report::build(report::Inputs {
        cfg,
        data,
        nodes: node_stats,
        manager,
        phase1_end_s: end_s,
        stopped_at,
        trace1: &trace,
        traffic1: &traffic1,
        phase2: &ph2,
        refs,
        host_phase1_s: host_s,
        host_phase2_s: host2_s,
    });
    Ok(ClusterOutcome {
        image: ph2.image,
        report,
        trace,
        processed: Vec::new(),
    })
}
