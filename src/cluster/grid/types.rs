//! What a grid run reports ([`GridReport`], per rank [`GridNodeReport`])
//! and produces ([`GridOutcome`]).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::cluster::phase1::ClockKind;
use crate::image::Image;
use crate::net::SimTrace;
use crate::node::grid::bricks::BrickPlacement;
use crate::node::grid::render::RendererKind;
use crate::node::grid::GridNodeStats;

/// Per rank, in the report.
#[derive(Debug, Clone, Serialize)]
pub struct GridNodeReport {
    /// The node's phase-1 numbers.
    #[serde(flatten)]
    pub stats: GridNodeStats,
    /// When it finished rendering (seconds).
    pub render_end_s: f64,
    /// Payload bytes it sent in phase 2.
    pub bytes_sent: u64,
}

/// The report of a grid cluster run (the keys of the cell report that
/// apply, plus the grid's own).
#[derive(Debug, Clone, Serialize)]
pub struct GridReport {
    /// Image size.
    pub image: [u32; 2],
    /// Volume samples per axis.
    pub volume_dims: [u64; 3],
    /// Bricks per axis.
    pub subvolumes: u32,
    /// Rendering nodes.
    pub n_nodes: usize,
    /// With a master rank.
    pub master: bool,
    /// Clock.
    pub clock: ClockKind,
    /// Network name.
    pub network: String,
    /// Profile name.
    pub profile: String,
    /// Placement.
    pub placement: BrickPlacement,
    /// Compositing strategy.
    pub compositor: String,
    /// Layer codec.
    pub codec: String,
    /// Frame time: end of phase 2 (seconds).
    pub frame_s: f64,
    /// Frames per second, `1 / frame_s` (the paper's unit).
    pub fps: f64,
    /// End of phase 1: the slowest node's render (seconds).
    pub render_s: f64,
    /// Phase 2 (compositing, with its network time), seconds.
    pub composite_s: f64,
    /// Payload bytes of phase 2.
    pub bytes_total: u64,
    /// Bytes per message kind.
    pub bytes_by_kind: BTreeMap<String, u64>,
    /// Bytes sent / raw bytes of the same layers at the codec's depth
    /// (RGBA8 or RGBA16).
    pub codec_ratio: f64,
    /// The brick renderer (`slice3d`, or adaptive with its blocks and τ).
    pub renderer: RendererKind,
    /// Texture bytes as rendered ÷ original bytes, over all bricks (the
    /// paper's 縮小率 with adaptive sampling; 1 for slice3d on scalars).
    pub size_ratio: f64,
    /// Preprocessing host seconds (adaptive build, min–max blocks): the
    /// slowest node's sum over its bricks.
    pub prepare_s: f64,
    /// Bricks whose texture alone exceeds a node's texture memory (device
    /// model): when not 0, the paper's hardware could not draw the frame
    /// (its "-"); the times charge them as uploads.
    pub oversized_bricks: u64,
    /// Per round: label, messages, bytes, raw bytes.
    pub rounds: Vec<(String, usize, u64, u64)>,
    /// Per rank.
    pub nodes: Vec<GridNodeReport>,
    /// Host seconds of phase 1 and 2.
    pub host_s: [f64; 2],
    /// Host seconds of the whole frame at the driver (view set-up, phase 1,
    /// phase 2; over a transport, the coordinator's).
    pub wall_s: f64,
    /// Bricks drawn from a texture kept from an earlier frame (all nodes).
    pub textures_cached: u64,
    /// What the transport measured (`--transport processes|tcp`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transport: Option<GridMeasured>,
}

/// What a grid run produced.
#[derive(Debug)]
pub struct GridOutcome {
    /// The image at the root.
    pub image: Image,
    /// The report.
    pub report: GridReport,
    /// Phase 1 and 2 timeline.
    pub trace: SimTrace,
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
    /// Worker to worker: per rank, its phase-2 wall and thread CPU seconds
    /// (from its log; empty with a master).
    pub phase2_ranks: Vec<(f64, f64)>,
    /// Worker to worker: seconds from the last worker's render result to
    /// the last pixels in (phase 2 once every node has rendered; 0 with a
    /// master).
    pub phase2_after_renders_s: f64,
    /// Set when `--on-failure reassign` moved lost workers' bricks to the
    /// survivors (who, when, in which phase, the cost).
    pub reassigned: Option<crate::cluster::report::transport::Reassigned>,
}
