//! One brick into one layer: the brick renderer is any function with the
//! shape of [`slice3d::render`] (a `VolumeInput` and options to an image and
//! [`SliceStats`]) that honours [`Slice3dOptions::brick`]; the node crops its
//! image to the brick's screen rectangle and quantises it at the layer codec's depth.

use std::sync::Arc;

use crate::base::Rect;
use crate::compositor::layer::{Depth, Layer};
use crate::data::Volume;
use crate::error::Result;
use crate::image::Image;
use crate::render::slice3d::brick::BrickFrame;
use crate::render::slice3d::planes::Planes;
use crate::render::slice3d::{self, Slice3dOptions};
use crate::render::slicing::SliceStats;
use crate::render::VolumeInput;

use super::bricks::{screen_rect, Brick};

/// The shape of a brick renderer: `slice3d::render` (or `render_prepared`
/// over a cached texture), or an adaptive one.
pub type RenderFn =
    dyn Fn(&VolumeInput, &Slice3dOptions) -> Result<(Image, SliceStats)> + Send + Sync;

/// A brick renderer: `slice3d::render`, or an adaptive one with the same shape.
pub type BrickRenderer = Arc<RenderFn>;

/// The default brick renderer: [`slice3d::render`].
pub fn slice3d_renderer() -> BrickRenderer {
    Arc::new(slice3d::render)
}

/// Which brick renderer a grid run uses (a value: it travels to remote
/// workers).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum RendererKind {
    /// `slice3d` at full resolution.
    Slice3d,
    /// Adaptive block sampling (`render --renderer adaptive`): each brick
    /// cut into `blocks^3` blocks reduced within `tolerance`. The stats'
    /// `texture_bytes` are the reduced bytes, `time_prepare_s` the build.
    Adaptive {
        /// Blocks per axis of each brick.
        blocks: u64,
        /// Tolerance `τ` (relative to the transfer function's range).
        tolerance: f64,
    },
}

impl RendererKind {
    /// The renderer.
    pub fn build(self) -> BrickRenderer {
        match self {
            RendererKind::Slice3d => slice3d_renderer(),
            RendererKind::Adaptive { blocks, tolerance } => {
                let a = crate::render::adaptive::AdaptiveOptions { blocks, tolerance };
                Arc::new(move |input: &VolumeInput, opts: &Slice3dOptions| {
                    crate::render::adaptive::render(input, opts, &a)
                        .map(|(img, st)| (img, st.slice))
                })
            }
        }
    }

    /// Textures a brick of `dims` samples is drawn as: 1 with `slice3d`;
    /// with adaptive sampling its blocks (each a texture at its own
    /// resolution), as many as the build cuts per axis.
    pub fn textures(self, dims: [u64; 3]) -> u64 {
        match self {
            RendererKind::Slice3d => 1,
            RendererKind::Adaptive { blocks, .. } => dims
                .iter()
                .map(|&n| crate::render::adaptive::axis::split(n, blocks).len() as u64 - 1)
                .product::<u64>()
                .max(1),
        }
    }

    /// Checks the options before any brick is rendered.
    pub fn check(self, opts: &Slice3dOptions) -> Result<()> {
        match self {
            RendererKind::Slice3d => slice3d::check(opts),
            RendererKind::Adaptive { blocks, tolerance } => crate::render::adaptive::check(
                opts,
                &crate::render::adaptive::AdaptiveOptions { blocks, tolerance },
            ),
        }
    }
}

/// A brick's layer and what it cost.
#[derive(Debug)]
pub struct BrickOutput {
    /// The subimage (premultiplied RGBA over the brick's rectangle).
    pub layer: Layer,
    /// The renderer's statistics.
    pub stats: SliceStats,
    /// The subimage before quantisation (premultiplied f32, row-major over
    /// the layer's rectangle).
    pub exact: Vec<[f32; 4]>,
}

/// The whole volume's slice planes for the frame (`None`: behind the eye).
pub fn whole_planes(whole: &VolumeInput, opts: &Slice3dOptions) -> Option<Planes> {
    let s = &whole.scene;
    Planes::new(
        &s.camera.view(s.image.width, s.image.height),
        &whole.volume,
        opts.slices,
    )
}

/// The layer a brick becomes: its visibility rank and its pixels' depth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LayerSpec {
    /// Visibility rank (0 nearest the eye).
    pub rank: u32,
    /// Fixed-point depth of the pixels (the layer codec's).
    pub depth: Depth,
}

/// Renders brick `b` (its samples in `vol`) of `whole` into the layer
/// `spec` describes. The brick's scene has a black background, so
/// its pixels are premultiplied RGBA without background.
pub fn render_brick(
    whole: &VolumeInput,
    planes: Planes,
    b: &Brick,
    vol: Arc<Volume>,
    spec: LayerSpec,
    opts: &Slice3dOptions,
    renderer: &RenderFn,
) -> Result<BrickOutput> {
    let s = &whole.scene;
    let view = s.camera.view(s.image.width, s.image.height);
    let rect = screen_rect(&view, &whole.volume, b);
    let mut scene = s.clone();
    scene.image.background = [0.0; 3];
    let input = VolumeInput {
        scene,
        volume: vol,
        range: whole.range,
    };
    let frame = BrickFrame {
        planes,
        origin: whole.volume.origin,
        spacing: whole.volume.spacing,
        whole_dims: whole.volume.dims,
        lo: b.lo,
        dims: b.dims,
        rect,
    };
    let (img, stats) = renderer(
        &input,
        &Slice3dOptions {
            brick: Some(frame),
            ..*opts
        },
    )?;
    // A brick whose min–max blocks are all transparent under the TF drew
    // nothing (every sample was skipped, every pixel is exactly zero): it
    // sends an empty rectangle, no pixels, and the composite is the same.
    let rect = if opts.empty_skip && stats.blocks > 0 && stats.blocks_empty == stats.blocks {
        Rect {
            x1: rect.x0,
            y1: rect.y0,
            ..rect
        }
    } else {
        rect
    };
    // The renderer returned the brick's rectangle (`Slice3dOptions::brick`).
    if (img.width, img.height) != (frame.rect.width(), frame.rect.height()) {
        return Err(crate::error::Error::Invalid(format!(
            "brick {}: the renderer drew {}x{} pixels for a {}x{} rectangle",
            b.id,
            img.width,
            img.height,
            frame.rect.width(),
            frame.rect.height()
        )));
    }
    let px = if rect.width() == 0 || rect.height() == 0 {
        Vec::new()
    } else {
        img.pixels
    };
    Ok(BrickOutput {
        layer: Layer::quantize(rect, spec.rank, spec.depth, &px),
        stats,
        exact: px,
    })
}
