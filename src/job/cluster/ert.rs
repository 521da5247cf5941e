//! The ERT mode options of `pvrsim cluster` (flattened into
//! [`crate::job::cluster::ClusterArgs`]): which structure the nodes test cells
//! against, how sharing travels, front-first help, and `--paper`, the
//! preset that reproduces the paper's protocol exactly.

use clap::Args;

use crate::render::cell::ert::ErtStructure;

/// ERT structure, sharing granularity and scheduling of the cluster's nodes.
#[derive(Debug, Clone, Args)]
pub struct ClusterErtArgs {
    /// What nodes test cells against. `pyramid` (default): a per-pixel
    /// max-pyramid (the sequential renderer's best test) and, with
    /// `--share`, per-pixel opacity levels combined by the manager so that
    /// opacity adds up across nodes (src/node/pixel_share/). `flat`: the
    /// paper's D x D table and its per-entry sharing.
    #[arg(long, value_enum)]
    pub ert_structure: Option<ErtStructure>,
    /// Front-first help (pyramid structure, with --share and --dlb): a node
    /// whose next cell lies more than this fraction of the frame's depth
    /// range behind the nearest node's asks (in its share) for that node's
    /// nearest cells, so that the front of the volume is scanned first and
    /// the cells behind it can be skipped. 0 turns it off.
    #[arg(long, value_name = "FRACTION", default_value_t = 0.3)]
    pub help_gap: f32,
    /// Front-first help: fraction of its unprocessed cells a node gives
    /// (its nearest ones). Default 0.33: the fastest on aorta view B, 8
    /// nodes, replicated data, of 0.25, 0.33, 0.4 (gap 0.3;
    /// docs/experiments/cluster.md).
    #[arg(long, value_name = "FRACTION", default_value_t = 0.33)]
    pub help_fraction: f64,
    /// Release ordering (pyramid structure, with --share): block edge in
    /// pixels of the release maps nodes exchange at the start of the frame,
    /// after which each node scans first the cells other nodes will cover
    /// soonest (src/node/release.rs). 0 turns it off (nearest-first, the
    /// default: measured slower on aorta view B, docs/experiments/cluster.md).
    /// Needs --share and the pyramid structure; --paper turns it off.
    #[arg(long, value_name = "PIXELS", default_value_t = 0)]
    pub release_block: u32,
    /// Release ordering: how long, as a fraction of the frame, a covered
    /// cell waits after the nodes in front start covering its blocks.
    #[arg(long, value_name = "FRACTION", default_value_t = 0.1)]
    pub release_lag: f32,
    /// Manager shards K for per-pixel sharing (with --share, the pyramid
    /// structure): the screen's 16 x 16 tiles are dealt to K shards in a
    /// lattice; shard 0 is the manager (load balancing, end of phase 1),
    /// shards 1..K run on their own PCs; each node sends each shard the
    /// changed pixels of its tiles and gets back its deltas
    /// (src/manager/shard.rs). Default: 1 up to 16 nodes, then ceil(N/16)
    /// (16 at 256 nodes). Must lie between 1 and the number of tiles.
    #[arg(long, value_name = "K")]
    pub manager_shards: Option<usize>,
    /// Global front-to-back schedule (replicated data, with --share): each
    /// node's part is cut into leaves (--schedule-leaf-cells), the leaves,
    /// by depth, into W waves, and every wave is dealt evenly over the
    /// nodes (owners keep a screen strip, the rest goes to the nodes holding
    /// less), so a back node scans the front nodes' nearest leaves first and
    /// its own back cells last (src/node/schedule.rs). Every node computes
    /// the schedule itself (charged: one cell record per leaf); nothing
    /// travels. 0 or 1: off (each node scans its part). Default with
    /// --share --dlb, the pyramid and replicated data: 4 when there are at
    /// least 2,500 cells per node and the parts are stacked along the view
    /// (--schedule-min-stacking), else off.
    #[arg(long, value_name = "W")]
    pub schedule_waves: Option<usize>,
    /// Global schedule: cells per leaf, the unit dealt (each node's part is
    /// cut by bisection into leaves of about this many cells, once per
    /// dataset). Smaller: finer balance, more keys to compute per frame.
    #[arg(long, value_name = "CELLS", default_value_t = crate::node::schedule::DEFAULT_LEAF_CELLS)]
    pub schedule_leaf_cells: usize,
    /// Global schedule: apply it only when the placement's parts are
    /// stacked along the view by at least this fraction of the depth range
    /// (the largest gap between a part's nearest probe leaf and the nearest
    /// of all, 4 coarse leaves per part). Default: 0.8 for the default
    /// schedule (aorta view B 0.85, view A 0.50, the demo 0.75 at 8 nodes),
    /// 0 (always) with --schedule-waves given.
    #[arg(long, value_name = "FRACTION")]
    pub schedule_min_stacking: Option<f64>,
    /// The paper's protocol exactly: flat D x D table, single-entry test,
    /// per-entry sharing (1 level, whole entries), no share window, no
    /// front-first help, no release ordering. Overrides --ert-structure,
    /// --share-levels, --share-sub, --share-window, --help-gap and
    /// --release-block.
    #[arg(long)]
    pub paper: bool,
}

/// The resolved ERT mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErtMode {
    /// Structure tested.
    pub structure: ErtStructure,
    /// Opacity levels shared (pixel levels for the pyramid, block levels for flat).
    pub share_levels: u8,
    /// Front-first help gap (0: off).
    pub help_gap: f32,
    /// Release ordering block edge (0: off).
    pub release_block: u32,
}

impl ClusterErtArgs {
    /// Resolves the mode from these flags and the `--share-levels` given
    /// (if any): the pyramid shares 4 levels per pixel by default (measured
    /// best on aorta view B, docs/experiments/cluster.md), flat 1 (the paper).
    pub fn resolve(&self, share_levels: Option<u8>) -> anyhow::Result<ErtMode> {
        anyhow::ensure!(
            self.help_gap.is_finite() && self.help_gap >= 0.0,
            "--help-gap must be a fraction >= 0 (0 = off), got {}",
            self.help_gap
        );
        anyhow::ensure!(
            self.help_fraction > 0.0 && self.help_fraction <= 1.0,
            "--help-fraction must be in (0, 1], got {}",
            self.help_fraction
        );
        anyhow::ensure!(
            self.release_lag.is_finite() && (0.0..=1.0).contains(&self.release_lag),
            "--release-lag must be a fraction in [0, 1], got {}",
            self.release_lag
        );
        if let Some(f) = self.schedule_min_stacking {
            anyhow::ensure!(
                f.is_finite() && f >= 0.0,
                "--schedule-min-stacking must be a fraction >= 0 (0 = always apply), got {f}"
            );
        }
        if let Some(k) = self.manager_shards {
            anyhow::ensure!(
                k >= 1,
                "--manager-shards {k}: must be at least 1 (1 = one manager, no sharding)"
            );
            anyhow::ensure!(
                !(self.paper && k > 1),
                "--manager-shards {k} with --paper: the paper's protocol has one manager \
                 (only per-pixel sharing is sharded)"
            );
        }
        if self.paper {
            return Ok(ErtMode {
                structure: ErtStructure::Flat,
                share_levels: 1,
                help_gap: 0.0,
                release_block: 0,
            });
        }
        let structure = self.ert_structure.unwrap_or(ErtStructure::Pyramid);
        Ok(ErtMode {
            structure,
            share_levels: share_levels.unwrap_or(match structure {
                ErtStructure::Pyramid => 4,
                ErtStructure::Flat => 1,
            }),
            help_gap: if structure == ErtStructure::Pyramid {
                self.help_gap
            } else {
                0.0
            },
            release_block: if structure == ErtStructure::Pyramid {
                self.release_block
            } else {
                0
            },
        })
    }
}
