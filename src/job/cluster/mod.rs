//! `pvrsim cluster`: render a scene on a simulated PC cluster (N nodes + a
//! manager): phase 1 scan conversion with ERT, weak sharing and DLB, phase 2
//! compositing; writes the image, a JSON report, a Gantt chart and a Chrome
//! trace, and prints a per-node summary.

pub mod ert;
pub mod grid;
pub mod load;
pub mod mesh;
pub mod pieces;

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;

use crate::cluster::{ClockKind, ClusterConfig, Phase1Config};
use crate::compositor::codec::{LayerCodecKind, ListCodecKind};
use crate::compositor::strategy::Compositing;
use crate::net::NetworkModel;
use crate::node::renderer::NodeErt;
use crate::node::{CostProfile, DataMode, NodeOptions, NodePolicy, PlacementMethod};
use crate::render::cell::{CellOrder, ErtSpan, Integrator};

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

/// `--codec`: a list codec (mesh frames: `rle`, `raw`) or an RGBA layer
/// codec (grid frames; there `rle` means `rle16`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CodecChoice {
    /// Empty runs collapsed (lists), the paper's RLE at 16 bits (layers).
    Rle,
    /// No compression.
    Raw,
    /// Layers: the paper's RLE at 16 bits a channel.
    Rle16,
    /// Layers: RGBA16.
    Raw16,
    /// Layers: IceT's active runs at 16 bits.
    Sparse16,
    /// Layers: the paper's RLE of RGBA8.
    RlePaper,
    /// Layers: IceT's active runs of RGBA8.
    Sparse,
}

impl CodecChoice {
    /// The list codec of a mesh frame; a layer-only codec is refused.
    pub fn list(self) -> anyhow::Result<ListCodecKind> {
        match self {
            CodecChoice::Rle => Ok(ListCodecKind::Rle),
            CodecChoice::Raw => Ok(ListCodecKind::Raw),
            c => anyhow::bail!(
                "--codec {}: a codec of RGBA layers (grid scenes); a mesh frame's segment \
                 lists take rle or raw",
                c.layers().name()
            ),
        }
    }

    /// The layer codec of a grid frame (`rle` is `rle16`).
    pub fn layers(self) -> LayerCodecKind {
        match self {
            CodecChoice::Rle | CodecChoice::Rle16 => LayerCodecKind::Rle16,
            CodecChoice::Raw => LayerCodecKind::Raw,
            CodecChoice::Raw16 => LayerCodecKind::Raw16,
            CodecChoice::Sparse16 => LayerCodecKind::Sparse16,
            CodecChoice::RlePaper => LayerCodecKind::RlePaper,
            CodecChoice::Sparse => LayerCodecKind::Sparse,
        }
    }
}

/// Options of `pvrsim cluster`.
#[derive(Debug, Clone, Args)]
#[command(mut_arg("ert", |a| a.help(crate::job::args::shared::CLUSTER_ERT_HELP)))]
pub struct ClusterArgs {
    /// Scene file (TOML, see the scene contract).
    pub scene: PathBuf,
    /// Number of rendering nodes (the manager is one more rank).
    #[arg(long, default_value_t = 8)]
    pub nodes: usize,
    /// Early termination threshold (declared once: [`crate::job::args::shared::ErtArg`];
    /// the help this command shows is `CLUSTER_ERT_HELP`).
    #[command(flatten)]
    pub ert: crate::job::args::shared::ErtArg,
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
    /// Default: 4 with the pyramid structure (per pixel), 1 with flat.
    #[arg(long, value_name = "L", value_parser = clap::value_parser!(u8).range(1..=16))]
    pub share_levels: Option<u8>,
    /// Level sharing: blocks per entry axis (1: whole entries).
    #[arg(long, value_name = "S", default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=15))]
    pub share_sub: u8,
    /// ERT structure, front-first help, `--paper`.
    #[command(flatten)]
    pub ert_mode: crate::job::cluster::ert::ClusterErtArgs,
    /// Shorthand for `--sharing manager`.
    #[arg(long, conflicts_with = "sharing")]
    pub share: bool,
    /// Dynamic load balancing: an idle node gets 1/3 of the cells of the
    /// node with the most unprocessed cells.
    #[arg(long)]
    pub dlb: bool,
    /// Where the cells live. `replicated` (default): every node holds the
    /// whole mesh (memory and the one-time distribution are printed), so
    /// DLB and front-first help move cell ids only (measured on aorta view
    /// B, 8 nodes: docs/experiments/cluster.md). `partitioned`: each node
    /// holds its part and cells move with their vertices (the paper; what
    /// `--paper` uses, and the only mode of the remote transports).
    #[arg(long, value_enum)]
    pub data: Option<crate::node::DataMode>,
    /// Compositing strategy of phase 2: `binary-swap`, `direct-send`,
    /// `radix-k` (k from `--radix-k`) or `master` (everything to rank 0).
    /// Default `binary-swap` (`master` with `--master`).
    #[arg(long)]
    pub compositor: Option<Compositing>,
    /// Codec of phase-2 messages: `rle` (empty runs collapsed) or `raw`;
    /// grid scenes: `rle16` (the paper's RLE at 16 bits a channel; `rle`
    /// means it there), `raw16`, `sparse16` (IceT's active runs), or the
    /// paper's 8-bit `raw`, `rle-paper`, `sparse` (up to 1.4/255 off the
    /// single-node image at d = 2).
    #[arg(long, value_enum, default_value_t = CodecChoice::Rle, hide_possible_values = true)]
    pub codec: CodecChoice,
    /// Network model: a preset (gbe, fast-ethernet, 10gbe, infiniband,
    /// ideal) or a TOML file (see configs/network/). Default: gbe. Only the
    /// virtual clock models time; with `--clock wall` it has no effect.
    #[arg(long, value_name = "NAME_OR_FILE")]
    pub network: Option<String>,
    /// `virtual`: discrete-event simulation, modelled times, deterministic.
    /// `wall`: real threads, wall-clock times, compute as really done.
    /// Default: virtual; `--transport` runs on wall time (with it, only
    /// `--clock wall` may be given).
    #[arg(long, value_enum, value_name = "CLOCK")]
    pub clock: Option<ClockKind>,
    /// Compute cost profile: `pentium4` (the paper's machine, fitted to its
    /// Table 1; built in), `calibrated` (this machine: profiles/calibrated.toml
    /// as `pvrsim calibrate` writes it, else the shipped
    /// configs/profiles/calibrated.toml), or a profile TOML file, read at run
    /// time. Default: pentium4. With `--clock wall` it has no effect.
    #[arg(long, value_name = "NAME_OR_FILE")]
    pub profile: Option<String>,
    /// Initial placement of cells on nodes: recursive coordinate bisection
    /// of the cell centroids in 3-D (`rcb`, the paper's object-space split),
    /// a Morton-curve cut (`morton`), or bisection of the centroids' screen
    /// positions for this view (`rcb-view`: every node owns a screen region
    /// with all its depths; view-dependent), or the pieces of a `.pvtu`
    /// scene (`pieces`: each node a contiguous run of them, as the solver
    /// wrote them). Default: `pieces` for a `.pvtu`, else `rcb`. On
    /// `--transport processes` or `tcp` with `pieces`, each worker reads its
    /// own pieces (the coordinator never reads the cells); another
    /// placement there reads the whole mesh in the coordinator and sends
    /// each worker its cells.
    #[arg(long, value_enum)]
    pub placement: Option<PlacementMethod>,
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
    /// report's `share_efficiency`, `ideal_speedup`, `speedup`,
    /// `speedup_frame` become null. The summary explains the terms:
    /// Tsc = a node's scan-conversion time (phase 1, no compositing);
    /// speed-up = sequential ÷ frame (frame-based) and ÷ Tsc max (Tsc-based,
    /// the paper's); ideal speed-up = Base Tsc max ÷ (sequential ÷ N);
    /// share efficiency = cells skipped by all nodes ÷ by the sequential run.
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
    /// Grid scenes (sort-last bricks).
    #[command(flatten)]
    pub grid: crate::job::args::grid::GridArgs,
    /// A frame series (`--frames`, `--turn`, `--series-csv`).
    #[command(flatten)]
    pub series: crate::job::series::args::SeriesArgs,
    /// Where the nodes run (`--transport`, `--workers`, ...).
    #[command(flatten)]
    pub net: crate::job::args::transport::TransportArgs,
}

/// Where `--profile calibrated` is read from: `profiles/calibrated.toml`
/// (what `pvrsim calibrate` writes) if it exists, else the shipped
/// `configs/profiles/calibrated.toml` (in the current directory, else in the
/// source tree).
pub fn calibrated_path() -> PathBuf {
    let own = Path::new("profiles/calibrated.toml");
    if own.exists() {
        return own.to_path_buf();
    }
    let local = Path::new("configs/profiles/calibrated.toml");
    if local.exists() {
        local.to_path_buf()
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/profiles/calibrated.toml")
    }
}

/// Resolves a profile name or file (read at run time); returns the profile
/// and the name the report shows (a file's path).
pub fn load_profile(name: &str) -> anyhow::Result<(CostProfile, String)> {
    if name == "pentium4" || name == "radeon9700" {
        return Ok((CostProfile::named(name)?, name.to_string()));
    }
    let path = if name == "calibrated" {
        calibrated_path()
    } else {
        PathBuf::from(name)
    };
    let shown = if name == "calibrated" {
        format!("calibrated ({})", path.display())
    } else {
        name.to_string()
    };
    let p = CostProfile::load(&path).with_context(|| {
        format!("--profile {name}: not pentium4, radeon9700, calibrated, or a readable profile TOML file")
    })?;
    Ok((p.costs, shown))
}

pub(crate) fn load_network(name: &str) -> anyhow::Result<NetworkModel> {
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

/// What validating [`ClusterArgs`] decided once
/// ([`crate::job::Valid::parsed`]): the job runs from these, not from the
/// raw options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterChoices {
    /// `--ert`: on with its threshold, or off.
    pub ert: crate::render::cell::ert::ErtMode,
    /// `--compositor`, `--radix-k`, `--master`.
    pub compositing: Compositing,
}

impl ClusterArgs {
    /// The compositing strategy `--compositor` and `--radix-k` name
    /// (default binary swap); `--radix-k` without `--compositor radix-k`
    /// is refused rather than ignored.
    pub fn compositing(&self) -> anyhow::Result<Compositing> {
        let c = self.compositor.unwrap_or_default();
        match self.grid.radix_k {
            None => Ok(c),
            Some(k) => c.with_group_size(k).map_err(|e| anyhow::anyhow!(e)),
        }
    }

    /// Whether ERT tables are shared (through the manager or by overlap).
    fn sharing_mode(&self) -> Sharing {
        if self.share {
            Sharing::Manager
        } else {
            self.sharing
        }
    }
}

/// The configuration of a mesh frame that validated options describe
/// (the validation layer ran before: [`crate::job::cluster::load`]).
pub fn config(v: &crate::job::Valid<'_, ClusterArgs>) -> anyhow::Result<ClusterConfig> {
    let (a, choices) = (v.args(), v.parsed());
    let network = a.network.as_deref().unwrap_or("gbe");
    let (profile, profile_name) = load_profile(a.profile.as_deref().unwrap_or("pentium4"))?;
    let mode = a.ert_mode.resolve(a.share_levels)?;
    let paper = a.ert_mode.paper;
    Ok(ClusterConfig {
        phase1: Phase1Config {
            nodes: a.nodes,
            node: NodeOptions {
                integrator: Integrator::Exact,
                partial_composition: !a.no_partial_composition,
                cell_order: CellOrder::FrontToBack,
                ert: NodeErt {
                    mode: choices.ert,
                    divisions: a.ert_table,
                    update_c: a.ert_update,
                    span: a.ert_span,
                    structure: mode.structure,
                    share_levels: mode.share_levels,
                    share_sub: if paper { 1 } else { a.share_sub },
                },
                canonical: a.canonical,
            },
            share: a.sharing_mode() == Sharing::Manager,
            overlap: a.sharing_mode() == Sharing::Overlap,
            dlb: a.dlb,
            data: if paper {
                DataMode::Partitioned
            } else {
                a.data.unwrap_or_default()
            },
            policy: NodePolicy {
                chunk: a.chunk,
                give_fraction: 1.0 / 3.0,
                min_grant: a.min_grant,
                progress_every: a.progress_every,
                share_window: if paper { 0 } else { a.share_window },
                help_gap: mode.help_gap,
                help_fraction: a.ert_mode.help_fraction,
                release_block: mode.release_block,
                release_lag: a.ert_mode.release_lag,
            },
            manager_shards: a.ert_mode.manager_shards,
            schedule_waves: a.ert_mode.schedule_waves.unwrap_or(
                if !paper
                    && choices.ert.is_on()
                    && a.sharing_mode() == Sharing::Manager
                    && a.dlb
                    && mode.structure == crate::render::cell::ert::ErtStructure::Pyramid
                    && a.data != Some(DataMode::Partitioned)
                {
                    crate::node::schedule::DEFAULT_WAVES
                } else {
                    0
                },
            ),
            schedule_leaf_cells: a.ert_mode.schedule_leaf_cells,
            schedule_min_cells: if a.ert_mode.schedule_waves.is_some() {
                0
            } else {
                crate::node::schedule::MIN_CELLS_PER_NODE
            },
            schedule_min_stacking: a.ert_mode.schedule_min_stacking.unwrap_or(
                if a.ert_mode.schedule_waves.is_some() {
                    0.0
                } else {
                    crate::node::schedule::MIN_STACKING
                },
            ),
            clock: a.clock.unwrap_or(ClockKind::Virtual),
            record_trace: true,
        },
        placement: a.placement.unwrap_or(PlacementMethod::Rcb),
        compositor: choices.compositing,
        codec: a.codec.list()?,
        network: load_network(network)?,
        network_name: network.to_string(),
        profile,
        profile_name,
        baselines: !a.no_baselines,
    })
}
