//! `pvrsim cluster`: render a scene on a simulated PC cluster (N nodes + a
//! manager): phase 1 scan conversion with ERT, weak sharing and DLB, phase 2
//! compositing; writes the image, a JSON report, a Gantt chart and a Chrome
//! trace, and prints a per-node summary.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;

use crate::cluster::{self, ClockKind, ClusterConfig, ClusterOutcome, Phase1Config};
use crate::net::NetworkModel;
use crate::node::renderer::NodeErt;
use crate::node::{CostProfile, NodeOptions, NodePolicy, PlacementMethod};
use crate::render::cell::{CellOrder, ErtSpan, Integrator};
use crate::render::RenderInput;

/// How ERT tables are shared between nodes (`--sharing`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Sharing {
    /// No sharing: each node tests against its own table.
    Off,
    /// Weak sharing through the manager (the paper).
    Manager,
    /// Weak sharing straight between nodes whose screen footprints overlap.
    Overlap,
}

/// Options of `pvrsim cluster`.
#[derive(Debug, Clone, Args)]
pub struct ClusterArgs {
    /// Scene file (TOML, see the scene contract).
    pub scene: PathBuf,
    /// Number of rendering nodes (the manager is one more rank).
    #[arg(long, default_value_t = 8)]
    pub nodes: usize,
    /// Early ray termination threshold; 1.0 turns ERT off (the `Base` and
    /// `DLB` rows of the paper's Table 2). The paper uses 0.9.
    #[arg(long = "ert", value_name = "THRESHOLD", default_value_t = 1.0)]
    pub ert: f32,
    /// ERT table of D x D entries over the whole image (the paper's best: 20).
    #[arg(long, value_name = "D", default_value_t = 20)]
    pub ert_table: u32,
    /// ERT update constant C: a node rebuilds its table after every
    /// (remaining cells)/C cells (the paper's best: 100).
    #[arg(long, value_name = "C", default_value_t = 100)]
    pub ert_update: u32,
    /// Which cells the table tests: `single` (cells inside one entry, the
    /// paper) or `multi` (every covered entry must be terminated in front).
    #[arg(long, value_enum, default_value_t = ErtSpan::Single)]
    pub ert_span: ErtSpan,
    /// Weak sharing of ERT tables (needs --ert < 1): `manager` (every node
    /// sends its table to the manager, which replies with the merged one),
    /// `overlap` (no manager for ERT: each node sends its table straight to
    /// the nodes whose screen footprints overlap its own) or `off`.
    #[arg(long, value_enum, default_value_t = Sharing::Off)]
    pub sharing: Sharing,
    /// Level sharing with `--sharing manager`: opacity levels `L` sent per
    /// block (1 with `--share-sub 1`: the paper's per-entry table). See
    /// `src/node/levels.rs`.
    #[arg(long, value_name = "L", default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=16))]
    pub share_levels: u8,
    /// Level sharing: blocks per entry axis (1: whole entries).
    #[arg(long, value_name = "S", default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=15))]
    pub share_sub: u8,
    /// Shorthand for `--sharing manager`.
    #[arg(long, conflicts_with = "sharing")]
    pub share: bool,
    /// Dynamic load balancing: an idle node gets 1/3 of the cells of the
    /// node with the most unprocessed cells.
    #[arg(long)]
    pub dlb: bool,
    /// Compositing strategy of phase 2: `binary-swap` or `direct-send`.
    #[arg(long, default_value = "binary-swap")]
    pub compositor: String,
    /// Codec of phase-2 messages: `rle` (empty runs collapsed) or `raw`.
    #[arg(long, default_value = "rle")]
    pub codec: String,
    /// Network model: a preset (gbe, fast-ethernet, 10gbe, infiniband,
    /// ideal) or a TOML file (see configs/network/).
    #[arg(long, default_value = "gbe")]
    pub network: String,
    /// `virtual`: discrete-event simulation, modelled times, deterministic.
    /// `wall`: real threads, wall-clock times, compute as really done.
    #[arg(long, value_enum, default_value_t = ClockKind::Virtual)]
    pub clock: ClockKind,
    /// Compute cost profile: `pentium4` (the paper's machine, fitted to its
    /// Table 1), `calibrated` (configs/profiles/calibrated.toml: this
    /// machine) or a profile TOML file.
    #[arg(long, default_value = "pentium4")]
    pub profile: String,
    /// Initial placement of cells on nodes: recursive coordinate bisection
    /// of the cell centroids in 3-D (`rcb`, the paper's object-space split),
    /// a Morton-curve cut (`morton`), or bisection of the centroids' screen
    /// positions for this view (`rcb-view`: every node owns a screen region
    /// with all its depths; view-dependent).
    #[arg(long, value_enum, default_value_t = PlacementMethod::Rcb)]
    pub placement: PlacementMethod,
    /// Most cells a node scans between two looks at its inbox (an ERT update
    /// point also ends a chunk). Smaller chunks let a donor answer work
    /// requests sooner (measured on aorta-small, 8 nodes: 1000 → every
    /// forward refused, 100 → 94 cells moved).
    #[arg(long, default_value_t = NodePolicy::default().chunk)]
    pub chunk: usize,
    /// With DLB and no sharing: a node reports its unprocessed-cell count to
    /// the manager every this many chunks.
    #[arg(long, default_value_t = NodePolicy::default().progress_every)]
    pub progress_every: u32,
    /// Most ERT shares a node keeps in flight to the manager (sent, reply
    /// not back yet); a node with less than one chunk left does not share.
    /// 0 = no limit and shares to the very end: the paper's protocol, under
    /// which the manager's queue grows with the node count (see
    /// docs/experiments/cluster.md, scaling).
    #[arg(long, default_value_t = NodePolicy::default().share_window)]
    pub share_window: u32,
    /// A donor refuses a work request below this many unprocessed cells.
    #[arg(long, default_value_t = NodePolicy::default().min_grant)]
    pub min_grant: usize,
    /// Store every segment instead of merging touching ones on insertion.
    #[arg(long)]
    pub no_partial_composition: bool,
    /// Nodes merge touching segments in a canonical order so the image does
    /// not depend on how cells are distributed: without ERT it is then bit
    /// for bit `pvrsim render --canonical`'s, for any node count. Costs list
    /// memory and phase-2 bytes (aorta-small view B, 8 nodes: 4.4x entries,
    /// 3.5x bytes). Off: insertion order, within ~1e-6 of the sequential image.
    #[arg(long)]
    pub canonical: bool,
    /// Skip the reference runs (sequential, and Base at the same N); the
    /// report's `share_efficiency`, `ideal_speedup`, `speedup` become null.
    #[arg(long)]
    pub no_baselines: bool,
    /// Override the scene's image width (keeps the camera).
    #[arg(long, requires = "height")]
    pub width: Option<u32>,
    /// Override the scene's image height.
    #[arg(long, requires = "width")]
    pub height: Option<u32>,
    /// Output PNG (the image gathered at rank 0).
    #[arg(short, long, default_value = "cluster.png")]
    pub output: PathBuf,
    /// Write the JSON report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write a per-node Gantt chart (PNG) here.
    #[arg(long)]
    pub timeline: Option<PathBuf>,
    /// Write the Chrome trace JSON (open in Perfetto) here.
    #[arg(long)]
    pub trace: Option<PathBuf>,
    /// Where the nodes run (`--transport`, `--workers`, ...).
    #[command(flatten)]
    pub net: super::transport_args::TransportArgs,
}

/// Resolves a profile name or file.
pub fn load_profile(name: &str) -> anyhow::Result<CostProfile> {
    if name == "pentium4" {
        return CostProfile::named(name);
    }
    let path = if name == "calibrated" {
        let local = Path::new("configs/profiles/calibrated.toml");
        if local.exists() {
            local.to_path_buf()
        } else {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/profiles/calibrated.toml")
        }
    } else {
        PathBuf::from(name)
    };
    Ok(CostProfile::load(&path)
        .with_context(|| format!("--profile {name}: not pentium4, calibrated, or a profile file"))?
        .costs)
}

fn load_network(name: &str) -> anyhow::Result<NetworkModel> {
    if NetworkModel::preset_names().any(|n| n == name) {
        return Ok(NetworkModel::from_name(name)?);
    }
    NetworkModel::load(Path::new(name)).with_context(|| {
        format!(
            "--network {name}: not a preset ({}) or a readable network TOML",
            NetworkModel::preset_names().collect::<Vec<_>>().join(", ")
        )
    })
}

/// The configuration the arguments describe.
pub fn config(a: &ClusterArgs) -> anyhow::Result<ClusterConfig> {
    anyhow::ensure!(
        a.ert > 0.0 && a.ert <= 1.0,
        "--ert must be in (0, 1] (1 = off)"
    );
    anyhow::ensure!(a.ert_table >= 1, "--ert-table must be at least 1");
    anyhow::ensure!(a.chunk >= 1, "--chunk must be at least 1");
    anyhow::ensure!(a.nodes >= 1, "--nodes must be at least 1");
    Ok(ClusterConfig {
        phase1: Phase1Config {
            nodes: a.nodes,
            node: NodeOptions {
                integrator: Integrator::Exact,
                partial_composition: !a.no_partial_composition,
                cell_order: CellOrder::FrontToBack,
                ert: NodeErt {
                    threshold: a.ert,
                    divisions: a.ert_table,
                    update_c: a.ert_update.max(1),
                    span: a.ert_span,
                    local_pyramid: false,
                    share_levels: a.share_levels,
                    share_sub: a.share_sub,
                },
                canonical: a.canonical,
            },
            share: a.share || a.sharing == Sharing::Manager,
            overlap: !a.share && a.sharing == Sharing::Overlap,
            dlb: a.dlb,
            policy: NodePolicy {
                chunk: a.chunk,
                give_fraction: 1.0 / 3.0,
                min_grant: a.min_grant.max(1),
                progress_every: a.progress_every.max(1),
                share_window: a.share_window,
            },
            clock: a.clock,
            record_trace: true,
        },
        placement: a.placement,
        compositor: a.compositor.clone(),
        codec: a.codec.clone(),
        network: load_network(&a.network)?,
        network_name: a.network.clone(),
        profile: load_profile(&a.profile)?,
        profile_name: a.profile.clone(),
        baselines: !a.no_baselines,
    })
}

/// Loads the scene and runs the cluster, writing nothing.
pub fn execute(a: &ClusterArgs) -> anyhow::Result<ClusterOutcome> {
    let (mut input, _) = RenderInput::load(&a.scene)
        .with_context(|| format!("cannot load scene {}", a.scene.display()))?;
    if let (Some(w), Some(h)) = (a.width, a.height) {
        anyhow::ensure!(w > 0 && h > 0, "--width and --height must be > 0");
        input = input.with_size(w, h);
    }
    let mut cfg = config(a)?;
    match a.net.apply(&mut cfg)? {
        None => cluster::run(&input, &cfg),
        Some(kind) => {
            let (mut out, measured) = a.net.run(kind, &input, &cfg)?;
            out.report.transport = Some(crate::cluster::remote::transport_section(
                &input, &cfg, &out, measured,
            )?);
            Ok(out)
        }
    }
}

/// Runs `pvrsim cluster`.
pub fn run(a: ClusterArgs) -> anyhow::Result<()> {
    let out = execute(&a)?;
    out.image.save_png(&a.output)?;
    println!("wrote {}", a.output.display());
    if let Some(p) = &a.report {
        std::fs::write(p, serde_json::to_string_pretty(&out.report)?)
            .with_context(|| format!("cannot write {}", p.display()))?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &a.trace {
        let f =
            std::fs::File::create(p).with_context(|| format!("cannot write {}", p.display()))?;
        out.trace.write_chrome_json(std::io::BufWriter::new(f))?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &a.timeline {
        cluster::timeline::draw(&out.trace, out.report.n_nodes, p)?;
        println!("wrote {}", p.display());
    }
    print!("{}", cluster::report::summary(&out.report));
    Ok(())
}
