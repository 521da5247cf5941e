//! A grid cluster run's settings ([`GridConfig`]).

use crate::cluster::phase1::ClockKind;
use crate::net::NetworkModel;
use crate::node::grid::bricks::BrickPlacement;
use crate::node::grid::render::RendererKind;
use crate::node::CostProfile;
use crate::render::slice3d::Slice3dOptions;

/// A grid cluster run's settings.
#[derive(Clone)]
pub struct GridConfig {
    /// Rendering nodes `P`.
    pub nodes: usize,
    /// Bricks per axis `d` (`d^3` bricks).
    pub subvolumes: u32,
    /// A master rank that renders nothing (rank 0).
    pub master: bool,
    /// Brick placement.
    pub placement: BrickPlacement,
    /// Compositing strategy.
    pub compositor: crate::compositor::strategy::Compositing,
    /// Layer codec.
    pub codec: crate::compositor::codec::LayerCodecKind,
    /// Slicer options (ERT, slices, classification).
    pub slice: Slice3dOptions,
    /// The brick renderer.
    pub renderer: RendererKind,
    /// Clock.
    pub clock: ClockKind,
    /// Network model and its name.
    pub network: NetworkModel,
    /// Network name.
    pub network_name: String,
    /// Cost profile and its name.
    pub profile: CostProfile,
    /// Profile name.
    pub profile_name: String,
    /// Record the timeline.
    pub record_trace: bool,
    /// Keep each node's brick textures across frames ([`crate::node::grid::cache`];
    /// `false`: prepare every brick every frame, to measure what it saves).
    pub texture_cache: bool,
}
