//! View-aligned texture slicing in software (the 3D-texture method of the
//! papers, `parallel-texture-vr-rle.txt`), on the CPU.
//!
//! Planes perpendicular to the view direction are drawn through the volume
//! ([`planes`]); on each plane every pixel fetches the 3D texture
//! trilinearly and classifies the sample ([`sample`]: post- or
//! pre-classification), corrects its opacity for the slice distance along
//! its ray, `α = 1 - (1 - o)^(δ / unit_distance)`, and blends it, back to
//! front with factors `(1, 1 - A_s)` as in the paper or front to back with
//! early ray termination ([`march`]). Min–max blocks of the volume are
//! tested against the transfer function once per frame, and samples in
//! transparent blocks are skipped per ray.
//!
//! Bands of pixel rows are rendered in parallel (rayon), each in small
//! square tiles of pixels; the hot loop is f32 with positions `start + k
//! step` per ray and a [`Lut`] for the classification, sampling the volume
//! copied into cache-friendly tiles ([`texture`]); the image does not
//! depend on the thread count or the layout.

pub mod brick;
pub mod march;
pub mod planes;
pub mod preint;
pub mod sample;
pub mod texture;

#[cfg(test)]
pub(crate) mod tests;

use std::time::Instant;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::image::Image;
use crate::render::slicing::{Classify, Lut, MinMaxBlocks, Order, SampleCounts, SliceStats};
use crate::render::VolumeInput;
use crate::scene::Projection;
use crate::with_texels;

pub use planes::SliceCount;

/// Edge of the square pixel tiles the frame is walked in.
const PIXEL_TILE: usize = 8;

/// Options of the 3D slicer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slice3dOptions {
    /// Post- (default), pre-classification or pre-integrated sample pairs.
    pub classify: Classify,
    /// Front to back with ERT (default) or back to front.
    pub order: Order,
    /// ERT threshold in `(0, 1]`; 1 = off (default 0.99, the scene contract).
    pub ert: f32,
    /// Slice count or spacing.
    pub slices: SliceCount,
    /// Skip samples in transparent min–max blocks (default on).
    pub empty_skip: bool,
    /// Render the input as one brick of a larger volume (sort-last
    /// parallel rendering): the whole's slice planes, only the samples the
    /// brick owns, only the pixels of its rectangle, and the image returned
    /// is that rectangle (its pixel `(0, 0)` the rectangle's `(x0, y0)`),
    /// not the whole frame. `None`: the whole.
    pub brick: Option<brick::BrickFrame>,
}

impl Default for Slice3dOptions {
    fn default() -> Self {
        Slice3dOptions {
            classify: Classify::Post,
            order: Order::FrontToBack,
            ert: 0.99,
            slices: SliceCount::Default,
            empty_skip: true,
            brick: None,
        }
    }
}

/// What does not change from frame to frame: the min–max blocks and the
/// 3D texture as the slicer samples it (the scalars tiled, or for
/// pre-classification the classified RGBA8 texture).
pub struct Prepared {
    /// Per-block scalar ranges.
    pub blocks: MinMaxBlocks,
    /// Pre-classified texture (`None` for post-classification).
    pub rgba: Option<Vec<[u8; 4]>>,
    /// The scalars in tiles ([`texture`]); `None`: sampled in the
    /// volume's own x-fastest layout.
    pub tiled: Option<texture::TiledVoxels>,
    /// Seconds spent building it.
    pub time_s: f64,
}

/// How the scalar texture is laid out in memory (the image is the same).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// Overlapping 16^3 tiles (default; see [`texture`]).
    Tiled,
    /// The volume as read, x fastest (no copy).
    Linear,
}

/// Builds the frame-independent data for `classify`, scalars tiled.
pub fn prepare(input: &VolumeInput, classify: Classify) -> Prepared {
    prepare_with(input, classify, Layout::Tiled)
}

/// Builds the frame-independent data for `classify` with the scalars in
/// `layout` (pre-classification samples its RGBA8 texture x-fastest).
pub fn prepare_with(input: &VolumeInput, classify: Classify, layout: Layout) -> Prepared {
    let t = Instant::now();
    let vol = &*input.volume;
    let blocks = with_texels!(&vol.voxels, d => MinMaxBlocks::new(d, vol.dims));
    let rgba = (classify == Classify::Pre).then(|| {
        let lut = Lut::new(&input.scene.transfer, input.range);
        with_texels!(&vol.voxels, d => sample::classify_voxels(d, &lut))
    });
    let tiled = (classify != Classify::Pre && layout == Layout::Tiled)
        .then(|| texture::TiledVoxels::new(&vol.voxels, vol.dims));
    Prepared {
        blocks,
        rgba,
        tiled,
        time_s: t.elapsed().as_secs_f64(),
    }
}

/// Checks options that can be wrong.
pub fn check(opts: &Slice3dOptions) -> Result<()> {
    if !(opts.ert > 0.0 && opts.ert <= 1.0) {
        return Err(Error::Invalid(format!(
            "--ert must be in (0, 1], got {}",
            opts.ert
        )));
    }
    match opts.slices {
        SliceCount::Count(0) => Err(Error::Invalid("--slices must be >= 1".into())),
        SliceCount::Spacing(d) if !(d > 0.0 && d.is_finite()) => Err(Error::Invalid(format!(
            "--spacing must be a finite distance > 0, got {d}"
        ))),
        _ => Ok(()),
    }
}

/// Renders `input` (prepare + frame); the stats hold both times.
pub fn render(input: &VolumeInput, opts: &Slice3dOptions) -> Result<(Image, SliceStats)> {
    check(opts)?;
    let prep = prepare(input, opts.classify);
    let (img, mut st) = render_prepared(input, &prep, opts)?;
    st.time_prepare_s = prep.time_s;
    Ok((img, st))
}

/// Renders one frame with data from [`prepare`] (which must have been
/// built for `opts.classify`).
pub fn render_prepared(
    input: &VolumeInput,
    prep: &Prepared,
    opts: &Slice3dOptions,
) -> Result<(Image, SliceStats)> {
    check(opts)?;
    let start = Instant::now();
    let scene = &input.scene;
    let vol = &*input.volume;
    let (w, h) = (scene.image.width, scene.image.height);
    let view = scene.camera.view(w, h);
    let bg = scene.image.background.map(|x| x as f32);
    let tf = &scene.transfer;
    let mut st = SliceStats {
        renderer: "slice3d",
        voxels: vol.len(),
        classify: Some(opts.classify),
        order: Some(opts.order),
        ert_threshold: opts.ert as f64,
        ert_error_bound: SliceStats::ert_bound(opts.ert, opts.order, tf),
        threads: rayon::current_num_threads(),
        blocks: prep.blocks.range.len() as u64,
        ..Default::default()
    };
    // A brick draws its rectangle only: a frame-sized buffer per brick
    // would be touched (and, in a fresh worker process, page-faulted) for
    // pixels it never covers.
    let (ox, oy, iw, ih) = brick::draw_area(opts.brick.as_ref(), w, h);
    let mut image = Image::new(iw, ih);
    for p in &mut image.pixels {
        *p = [bg[0], bg[1], bg[2], 0.0];
    }
    let planes = match &opts.brick {
        Some(b) => Some(b.planes),
        None => planes::Planes::new(&view, vol, opts.slices),
    };
    let Some(planes) = planes.filter(|_| iw > 0 && ih > 0) else {
        st.time_render_s = start.elapsed().as_secs_f64();
        return Ok((image, st));
    };
    st.slices = planes.n;
    st.slice_spacing = planes.delta;
    let lut = Lut::new(tf, input.range);
    let table = (opts.classify == Classify::Preint).then(|| {
        preint::PreintTable::new(&lut, input.range, (planes.delta / tf.unit_distance) as f32)
    });
    let t_classify = Instant::now();
    let opaque = if opts.empty_skip {
        match &table {
            Some(t) => prep
                .blocks
                .range
                .iter()
                .map(|r| !t.transparent(r[0], r[1]))
                .collect(),
            None => prep.blocks.opaque(&lut),
        }
    } else {
        vec![true; prep.blocks.range.len()]
    };
    st.blocks_empty = opaque.iter().filter(|&&o| !o).count() as u64;
    let nb = prep.blocks.nb.map(|x| x as usize);
    let grid = march::Grid::new(
        vol.dims,
        nb,
        &opaque,
        if opts.order == Order::FrontToBack {
            opts.ert
        } else {
            2.0
        },
    );
    st.time_classify_s = t_classify.elapsed().as_secs_f64();
    let nx = vol.dims[0] as usize;
    let nxy = nx * vol.dims[1] as usize;
    let ud = tf.unit_distance;
    let ortho = matches!(scene.camera.projection, Projection::Orthographic { .. });

    // Pixels go to the threads in bands of PIXEL_TILE rows, and a band is
    // walked in PIXEL_TILE-square tiles: the rays of a tile pass through
    // the same texture tiles one after the other, while they are cached.
    let run = |s: &(dyn Fn(&planes::RaySamples, &mut SampleCounts) -> [f32; 4] + Sync),
               image: &mut Image| {
        let w = iw as usize;
        image
            .pixels
            .par_chunks_mut(w * PIXEL_TILE)
            .enumerate()
            .map(|(band, rows)| {
                crate::base::cancel::checkpoint();
                let mut n = SampleCounts::default();
                let nrows = rows.len() / w;
                for i0 in (0..w).step_by(PIXEL_TILE) {
                    for dj in 0..nrows {
                        let j = band * PIXEL_TILE + dj;
                        for i in i0..(i0 + PIXEL_TILE).min(w) {
                            let px = &mut rows[dj * w + i];
                            let (x, y) = (ox + i as u32, oy + j as u32);
                            let r = match &opts.brick {
                                None => planes::ray_samples(&view, &planes, vol, ud, x, y),
                                Some(b) => brick::ray_samples(&view, b, ud, x, y),
                            };
                            let Some(r) = r else {
                                continue;
                            };
                            n.covered += 1;
                            let [c0, c1, c2, a] = s(&r, &mut n);
                            let t = 1.0 - a;
                            *px = [c0 + t * bg[0], c1 + t * bg[1], c2 + t * bg[2], a];
                        }
                    }
                }
                n
            })
            .reduce(SampleCounts::default, SampleCounts::merge)
    };

    // The scalar texture in the prepared layout; `$x` names it in `$body`.
    macro_rules! with_texture {
        ($x:ident => $body:expr) => {
            match &prep.tiled {
                Some(tv) => with_texels!(&tv.voxels, data => {
                    let $x = texture::Tiled { data, nt: tv.nt };
                    $body
                }),
                None => with_texels!(&vol.voxels, data => {
                    let $x = texture::Linear { data, nx, nxy };
                    $body
                }),
            }
        };
    }
    let counts = match opts.classify {
        Classify::Post => with_texture!(tex => {
            if ortho {
                let baked = lut.baked((planes.delta / ud) as f32);
                let s = sample::PostBaked { tex, lut: &lut, baked: &baked };
                run(&|r, n| march::march(&s, &grid, r, opts.order, n), &mut image)
            } else {
                let s = sample::PostSigma { tex, lut: &lut };
                run(&|r, n| march::march(&s, &grid, r, opts.order, n), &mut image)
            }
        }),
        Classify::Preint => {
            let t = table.as_ref().expect("built for preint");
            with_texture!(tex => {
                let v = preint::Scalars { tex, lut: &lut };
                if ortho {
                    let sg = preint::Baked(t);
                    run(&|r, n| preint::march_pairs(&v, t, &sg, &grid, r, opts.order, n), &mut image)
                } else {
                    let sg = preint::Scaled(t);
                    run(&|r, n| preint::march_pairs(&v, t, &sg, &grid, r, opts.order, n), &mut image)
                }
            })
        }
        Classify::Pre => {
            let rgba = prep.rgba.as_deref().ok_or_else(|| {
                Error::Invalid("internal: slice3d prepared for post-classification".into())
            })?;
            let s = sample::Pre { rgba, nx, nxy };
            run(
                &|r, n| march::march(&s, &grid, r, opts.order, n),
                &mut image,
            )
        }
    };
    st.add_counts(&counts);
    st.texture_bytes = match (&prep.rgba, &prep.tiled) {
        (Some(t), _) => 4 * t.len() as u64,
        (None, Some(tv)) => tv.voxels.bytes(),
        (None, None) => vol.voxels.bytes(),
    };
    st.time_render_s = start.elapsed().as_secs_f64();
    Ok((image, st))
}
