//! Adaptive block sampling (`parallel-texture-vr-rle.txt` §4.2, 適応的サンプリング):
//! the volume (or a brick of it) is cut into `b^3` blocks, each block's
//! resolution is halved (2x2x2 averaging) while its error against the
//! original stays under the tolerance ([`build`]), and the blocks are drawn
//! at their own resolution by view-aligned slicing with `slice3d`'s planes,
//! samples, classification and compositing ([`sample`] defines the drawn
//! field and why it has no cracks).
//!
//! # Drawing order
//!
//! The paper draws the blocks far to near, each with the slices that cut
//! it. Every sample of a pixel lies in exactly one block, and the over
//! operator is associative, so compositing block after block far to near
//! gives, per pixel, the composite of its samples in depth order — which is
//! what the march does per ray (as `slice3d` does for the slices, see
//! [`slice3d::march`](crate::render::slice3d::march)): the same global
//! slice planes across all blocks, each sample fetched from its block.
//!
//! # Post-classification only
//!
//! The reduced blocks hold scalars; pre-classification (an RGBA8 texture of
//! the classified voxels) would reduce colours instead, a different method:
//! asking for it is an error.

pub mod axis;
pub mod build;
pub mod sample;

#[cfg(test)]
mod tests;

use std::time::Instant;

use rayon::prelude::*;

pub use build::AdaptiveVolume;

use crate::error::{Error, Result};
use crate::image::Image;
use crate::render::slice3d::{march, planes, Slice3dOptions};
use crate::render::slicing::blocks::BLOCK;
use crate::render::slicing::{Classify, Lut, MinMaxBlocks, Order, SampleCounts, SliceStats};
use crate::render::VolumeInput;
use crate::scene::Projection;
use crate::with_texels;

/// Options of adaptive block sampling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveOptions {
    /// Blocks per axis `b` (`b^3` blocks).
    pub blocks: u64,
    /// Tolerance `τ`: RMS error per block at most `τ R`, `R` the scalar
    /// range of the transfer function (see [`build`]).
    pub tolerance: f64,
}

impl Default for AdaptiveOptions {
    fn default() -> Self {
        AdaptiveOptions {
            blocks: 8,
            tolerance: 0.05,
        }
    }
}

/// What the preprocessing did (beside the frame's [`SliceStats`]).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct AdaptiveStats {
    /// Blocks per axis actually made (`b`, capped by the samples per axis).
    pub blocks_per_axis: [usize; 3],
    /// Blocks in all.
    pub blocks: u64,
    /// Tolerance `τ`.
    pub tolerance: f64,
    /// The range `R` the tolerance is relative to.
    pub range: f64,
    /// Bytes of the reduced blocks.
    pub bytes_reduced: u64,
    /// Bytes of the original volume.
    pub bytes_original: u64,
    /// The paper's 縮小率: `bytes_reduced / bytes_original`.
    pub size_ratio: f64,
    /// Preprocessing seconds.
    pub build_s: f64,
    /// Blocks per level (index 0 = full resolution).
    pub levels: Vec<u64>,
    /// RMS of `v - ṽ` over all original samples, divided by `R`.
    pub rms_error_rel: f64,
    /// Largest block RMS error divided by `R` (at most `τ`).
    pub max_block_rms_rel: f64,
}

impl AdaptiveStats {
    /// The statistics of a built volume.
    pub fn of(av: &AdaptiveVolume) -> AdaptiveStats {
        AdaptiveStats {
            blocks_per_axis: av.nb,
            blocks: av.blocks.len() as u64,
            tolerance: av.tolerance,
            range: av.range,
            bytes_reduced: av.bytes(),
            bytes_original: av.bytes_original,
            size_ratio: av.size_ratio(),
            build_s: av.build_s,
            levels: av.level_histogram(),
            rms_error_rel: av.rms_error() / av.range,
            max_block_rms_rel: av.blocks.iter().map(|b| b.rms).fold(0.0, f64::max) / av.range,
        }
    }
}

/// A frame's statistics: the slicer's and the preprocessing's.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct AdaptiveRenderStats {
    /// Slices, samples, skipping, times (`renderer = "adaptive"`).
    #[serde(flatten)]
    pub slice: SliceStats,
    /// Blocks, levels, size ratio, build time.
    pub adaptive: AdaptiveStats,
}

/// Checks options that can be wrong (the slicer's and ours).
pub fn check(opts: &Slice3dOptions, a: &AdaptiveOptions) -> Result<()> {
    crate::render::slice3d::check(opts)?;
    build::check(a.blocks, a.tolerance)?;
    if opts.classify == Classify::Pre {
        return Err(Error::Invalid(
            "adaptive sampling reduces scalars: it needs --classify post \
             (pre-classification would average colours, another method)"
                .into(),
        ));
    }
    Ok(())
}

/// Builds the blocks with `τ` relative to the input's scalar range.
pub fn prepare(input: &VolumeInput, a: &AdaptiveOptions) -> Result<AdaptiveVolume> {
    AdaptiveVolume::build_in_range(
        &input.volume,
        a.blocks,
        a.tolerance,
        input.range[1] - input.range[0],
    )
}

/// Builds the blocks and renders one frame (the shape of
/// [`slice3d::render`](crate::render::slice3d::render)); `time_prepare_s`
/// is the build time.
pub fn render(
    input: &VolumeInput,
    opts: &Slice3dOptions,
    a: &AdaptiveOptions,
) -> Result<(Image, AdaptiveRenderStats)> {
    check(opts, a)?;
    let av = prepare(input, a)?;
    let (img, mut st) = render_prepared(input, &av, opts)?;
    st.slice.time_prepare_s = av.build_s;
    Ok((img, st))
}

/// Min–max blocks of the adaptive field: each `BLOCK^3` cell block gets the
/// union of the stored ranges of the adaptive blocks holding its samples
/// (`ṽ` is a convex combination of a block's stored samples, and `F` of
/// `ṽ` at the cell corners, so this bounds `F` in the block).
fn min_max(av: &AdaptiveVolume) -> MinMaxBlocks {
    let nb: [u64; 3] = std::array::from_fn(|a| (av.dims[a] - 1).div_ceil(BLOCK).max(1));
    let span = |a: usize, b: u64| {
        let lo = (b * BLOCK) as usize;
        let hi = ((b + 1) * BLOCK).min(av.dims[a] - 1) as usize;
        av.block_of[a][lo] as usize..=av.block_of[a][hi] as usize
    };
    let mut range = Vec::with_capacity((nb[0] * nb[1] * nb[2]) as usize);
    for bz in 0..nb[2] {
        for by in 0..nb[1] {
            for bx in 0..nb[0] {
                let mut r = [f32::INFINITY, f32::NEG_INFINITY];
                for z in span(2, bz) {
                    for y in span(1, by) {
                        for x in span(0, bx) {
                            let br = av.blocks[(z * av.nb[1] + y) * av.nb[0] + x].range;
                            r = [r[0].min(br[0]), r[1].max(br[1])];
                        }
                    }
                }
                range.push(r);
            }
        }
    }
    MinMaxBlocks { nb, range }
}

/// Renders one frame from built blocks.
pub fn render_prepared(
    input: &VolumeInput,
    av: &AdaptiveVolume,
    opts: &Slice3dOptions,
) -> Result<(Image, AdaptiveRenderStats)> {
    crate::render::slice3d::check(opts)?;
    if opts.classify == Classify::Pre {
        return Err(Error::Invalid(
            "adaptive sampling needs --classify post".into(),
        ));
    }
    let vol = &*input.volume;
    if vol.dims != av.dims {
        return Err(Error::Invalid(format!(
            "internal: adaptive blocks built for {:?} samples, volume has {:?}",
            av.dims, vol.dims
        )));
    }
    let start = Instant::now();
    let scene = &input.scene;
    let (w, h) = (scene.image.width, scene.image.height);
    let view = scene.camera.view(w, h);
    let bg = scene.image.background.map(|x| x as f32);
    let tf = &scene.transfer;
    let mm = min_max(av);
    let mut st = SliceStats {
        renderer: "adaptive",
        voxels: vol.len(),
        classify: Some(opts.classify),
        order: Some(opts.order),
        ert_threshold: opts.ert as f64,
        ert_error_bound: SliceStats::ert_bound(opts.ert, opts.order, tf),
        threads: rayon::current_num_threads(),
        blocks: mm.range.len() as u64,
        texture_bytes: av.bytes(),
        ..Default::default()
    };
    let stats = |st: SliceStats| AdaptiveRenderStats {
        slice: st,
        adaptive: AdaptiveStats::of(av),
    };
    // A brick draws (and returns) its rectangle only, as slice3d.
    let (ox, oy, iw, ih) = crate::render::slice3d::brick::draw_area(opts.brick.as_ref(), w, h);
    let mut image = Image::new(iw, ih);
    for p in &mut image.pixels {
        *p = [bg[0], bg[1], bg[2], 0.0];
    }
    // A brick of a larger volume (sort-last): the whole's planes and the
    // brick's clip, exactly as slice3d (see `slice3d::brick`), so bricks
    // drawn adaptively meet without seams; the blocks are the brick's own.
    let planes = match &opts.brick {
        Some(b) => Some(b.planes),
        None => planes::Planes::new(&view, vol, opts.slices),
    };
    let Some(planes) = planes.filter(|_| iw > 0 && ih > 0) else {
        st.time_render_s = start.elapsed().as_secs_f64();
        return Ok((image, stats(st)));
    };
    st.slices = planes.n;
    st.slice_spacing = planes.delta;
    let lut = Lut::new(tf, input.range);
    let opaque = if opts.empty_skip {
        mm.opaque(&lut)
    } else {
        vec![true; mm.range.len()]
    };
    st.blocks_empty = opaque.iter().filter(|&&o| !o).count() as u64;
    let grid = march::Grid::new(
        vol.dims,
        mm.nb.map(|x| x as usize),
        &opaque,
        if opts.order == Order::FrontToBack {
            opts.ert
        } else {
            2.0
        },
    );
    let ud = tf.unit_distance;
    let ortho = matches!(scene.camera.projection, Projection::Orthographic { .. });
    let run = |s: &(dyn Fn(&planes::RaySamples, &mut SampleCounts) -> [f32; 4] + Sync),
               image: &mut Image| {
        image
            .pixels
            .par_chunks_mut(iw as usize)
            .enumerate()
            .map(|(j, row)| {
                crate::base::cancel::checkpoint();
                let mut n = SampleCounts::default();
                for (i, px) in row.iter_mut().enumerate() {
                    let (x, y) = (ox + i as u32, oy + j as u32);
                    let r = match &opts.brick {
                        None => planes::ray_samples(&view, &planes, vol, ud, x, y),
                        Some(b) => crate::render::slice3d::brick::ray_samples(&view, b, ud, x, y),
                    };
                    let Some(r) = r else {
                        continue;
                    };
                    n.covered += 1;
                    let [c0, c1, c2, a] = s(&r, &mut n);
                    let t = 1.0 - a;
                    *px = [c0 + t * bg[0], c1 + t * bg[1], c2 + t * bg[2], a];
                }
                n
            })
            .reduce(SampleCounts::default, SampleCounts::merge)
    };
    let counts = with_texels!(&av.samples, data => {
        let field = || sample::Field { av, data };
        if ortho {
            let baked = lut.baked((planes.delta / ud) as f32);
            let s = sample::Baked { field: field(), lut: &lut, baked: &baked };
            run(&|r, n| march::march(&s, &grid, r, opts.order, n), &mut image)
        } else {
            let s = sample::Sigma { field: field(), lut: &lut };
            run(&|r, n| march::march(&s, &grid, r, opts.order, n), &mut image)
        }
    });
    st.add_counts(&counts);
    st.time_render_s = start.elapsed().as_secs_f64();
    Ok((image, stats(st)))
}
