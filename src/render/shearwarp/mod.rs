//! Shear-warp volume rendering of regular grids (Lacroute and Levoy 1994,
//! "Fast volume rendering using a shear-warp factorization of the viewing
//! transformation"), orthographic views, object order, on the CPU.
//!
//! - [`prepare`] (view-independent, like VolPack's classification): for
//!   each of the three principal axes the scalars in that axis's slice
//!   order and the run-length encoding of their cell scanlines into
//!   transparent / non-transparent runs under the transfer function
//!   ([`rle`]); [`prepare_for_view`] builds only the view's axis (one
//!   frame). A transfer-function edit goes through
//!   [`Prepared::reclassify`]: the runs are kept when every skipped value
//!   stays transparent, else runs over the volume's min-max blocks stand in
//!   until [`Prepared::refine`] (both exact).
//! - per frame ([`render_prepared`]): the factorisation ([`factor`]:
//!   principal axis, shear, translation, warp), the slices composited front
//!   to back into the intermediate image with bilinear resampling inside
//!   each slice, opacity corrected for the sheared step `δ`
//!   (`α = 1 - (1 - o)^(δ / unit_distance)`), transparent runs skipped and
//!   opaque pixels skipped by skip links ([`composite`]), then the 2D
//!   affine warp to the final image ([`warp`]).
//!
//! Perspective views are refused with an error naming the projection
//! (Lacroute's perspective factorisation is not implemented).

pub mod composite;
pub mod factor;
pub mod rle;
pub mod warp;

use std::time::Instant;

use rayon::prelude::*;

use crate::data::Voxels;
use crate::error::{Error, Result};
use crate::image::Image;
use crate::render::slicing::{Classify, Lut, MinMaxBlocks, Order, SampleCounts, SliceStats, Texel};
use crate::render::VolumeInput;
use crate::scene::{Projection, TransferFunction};
use crate::with_texels;

use composite::{band, slice_steps, Slices};
use factor::Factor;
use rle::{AxisRle, Encoding};

/// Options of the shear-warp renderer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShearWarpOptions {
    /// ERT threshold in `(0, 1]` (default 0.99, the scene contract).
    pub ert: f32,
    /// Skip the transparent runs (default on; off visits every cell).
    pub empty_skip: bool,
}

impl Default for ShearWarpOptions {
    fn default() -> Self {
        ShearWarpOptions {
            ert: 0.99,
            empty_skip: true,
        }
    }
}

/// The run-length encodings of one volume, in its voxel type.
#[derive(Debug, Clone)]
pub enum Encoded {
    /// u8 voxels.
    U8(Encoding<u8>),
    /// u16 voxels.
    U16(Encoding<u16>),
    /// i16 voxels.
    I16(Encoding<i16>),
    /// f32 voxels.
    F32(Encoding<f32>),
}

/// What does not change from frame to frame.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The three encodings.
    pub encoded: Encoded,
    /// Volume dims the encodings were built for.
    pub dims: [u64; 3],
    /// Seconds spent building it.
    pub time_s: f64,
    /// The volume's min-max blocks (transfer-function independent): built
    /// by [`prepare`], or by the first [`Prepared::reclassify`] that needs
    /// them after [`prepare_for_view`].
    pub blocks: Option<MinMaxBlocks>,
    /// The lookup table of the transfer function and scalar range last
    /// prepared for, reused by frames with the same ones.
    pub lut: (TransferFunction, [f64; 2], Lut),
}

/// Builds the three run-length encodings of `input`'s volume under its
/// transfer function (every view direction; VolPack's classification
/// builds the same three) and the volume's min-max blocks (for
/// [`Prepared::reclassify`]).
pub fn prepare(input: &VolumeInput) -> Prepared {
    let mut p = prepare_axes(input, [true; 3]);
    let t = Instant::now();
    p.blocks = Some(min_max_blocks(&input.volume));
    p.time_s += t.elapsed().as_secs_f64();
    p
}

/// The min-max blocks of `vol`.
fn min_max_blocks(vol: &crate::data::Volume) -> MinMaxBlocks {
    with_texels!(&vol.voxels, d => MinMaxBlocks::new(d, vol.dims))
}

/// Builds only the encoding the scene's view needs (its principal axis):
/// a third of [`prepare`]'s time and memory, for one frame.
pub fn prepare_for_view(input: &VolumeInput) -> Prepared {
    let scene = &input.scene;
    let view = scene.camera.view(scene.image.width, scene.image.height);
    let c = Factor::new(&view, &input.volume).principal;
    prepare_axes(input, std::array::from_fn(|a| a == c))
}

/// Builds the encodings of the principal axes `c` with `want[c]`.
fn prepare_axes(input: &VolumeInput, want: [bool; 3]) -> Prepared {
    let t = Instant::now();
    let vol = &*input.volume;
    let lut = Lut::new(&input.scene.transfer, input.range);
    let d = vol.dims.map(|x| x as usize);
    let encoded = match &vol.voxels {
        Voxels::U8(v) => Encoded::U8(Encoding::for_axes(v, d, &lut, want)),
        Voxels::U16(v) => Encoded::U16(Encoding::for_axes(v, d, &lut, want)),
        Voxels::I16(v) => Encoded::I16(Encoding::for_axes(v, d, &lut, want)),
        Voxels::F32(v) => Encoded::F32(Encoding::for_axes(v, d, &lut, want)),
    };
    Prepared {
        encoded,
        dims: vol.dims,
        time_s: t.elapsed().as_secs_f64(),
        blocks: None,
        lut: (input.scene.transfer.clone(), input.range, lut),
    }
}

impl Prepared {
    /// Makes the encodings exact for `input`'s transfer function (the same
    /// volume, a new TF; [`rle::AxisRle::reclassify`]): an edit that keeps
    /// every skipped value transparent keeps the runs (microseconds); one
    /// that reveals skipped values classifies the volume's min-max blocks
    /// (built once per volume) and runs over whole blocks
    /// (exact, coarser: frames take more samples until [`Self::refine`]).
    /// Returns true when the runs changed. The time is added to `time_s`.
    pub fn reclassify(&mut self, input: &VolumeInput) -> bool {
        let t = Instant::now();
        let lut = Lut::new(&input.scene.transfer, input.range);
        let keep = self.exact_under(&lut);
        self.lut = (input.scene.transfer.clone(), input.range, lut);
        let lut = &self.lut.2;
        if keep {
            self.time_s += t.elapsed().as_secs_f64();
            return false;
        }
        let blocks = self
            .blocks
            .get_or_insert_with(|| min_max_blocks(&input.volume));
        // The cells' test, on each block's range (widened the same way).
        let opaque: Vec<bool> = blocks
            .range
            .iter()
            .map(|&[lo, hi]| rle::cell_opaque(lut, lo, hi))
            .collect();
        let did = match &mut self.encoded {
            Encoded::U8(e) => e.reclassify(lut, blocks, &opaque),
            Encoded::U16(e) => e.reclassify(lut, blocks, &opaque),
            Encoded::I16(e) => e.reclassify(lut, blocks, &opaque),
            Encoded::F32(e) => e.reclassify(lut, blocks, &opaque),
        };
        self.time_s += t.elapsed().as_secs_f64();
        did
    }

    /// True when every built axis's runs are exact under `lut`.
    fn exact_under(&self, lut: &Lut) -> bool {
        fn all<T: Texel>(e: &Encoding<T>, lut: &Lut) -> bool {
            e.axis.iter().flatten().all(|a| a.exact_under(lut))
        }
        match &self.encoded {
            Encoded::U8(e) => all(e, lut),
            Encoded::U16(e) => all(e, lut),
            Encoded::I16(e) => all(e, lut),
            Encoded::F32(e) => all(e, lut),
        }
    }

    /// Re-encodes every built axis per cell under `input`'s transfer
    /// function (what [`prepare`] does; after [`Self::reclassify`] fell back
    /// to block runs, this restores the per-cell skipping).
    pub fn refine(&mut self, input: &VolumeInput) {
        let t = Instant::now();
        let lut = Lut::new(&input.scene.transfer, input.range);
        match &mut self.encoded {
            Encoded::U8(e) => e.classify(&lut),
            Encoded::U16(e) => e.classify(&lut),
            Encoded::I16(e) => e.classify(&lut),
            Encoded::F32(e) => e.classify(&lut),
        }
        self.lut = (input.scene.transfer.clone(), input.range, lut);
        self.time_s += t.elapsed().as_secs_f64();
    }
}

/// The encoding of principal axis `c`, exact under `lut`.
fn axis_of<'a, T: Texel>(e: &'a Encoding<T>, c: usize, lut: &Lut) -> Result<&'a AxisRle<T>> {
    let a = e.axis[c].as_ref().ok_or_else(|| {
        Error::Invalid(format!(
            "internal: the shear-warp encodings were prepared without principal axis {c} of \
             this view (use shearwarp::prepare for every view)"
        ))
    })?;
    if !a.exact_under(lut) {
        return Err(Error::Invalid(
            "the shear-warp encodings were built for a transfer function (or scalar range) \
             under which values of this one were transparent: call Prepared::reclassify first"
                .into(),
        ));
    }
    Ok(a)
}

/// Checks options and the scene: the ERT threshold, and an orthographic
/// camera whose eye plane has the whole volume in front of it.
pub fn check(input: &VolumeInput, opts: &ShearWarpOptions) -> Result<()> {
    if !(opts.ert > 0.0 && opts.ert <= 1.0) {
        return Err(Error::Invalid(format!(
            "--ert must be in (0, 1], got {}",
            opts.ert
        )));
    }
    let scene = &input.scene;
    if let Projection::Perspective { fov_y_deg } = scene.camera.projection {
        return Err(Error::Invalid(format!(
            "--renderer shearwarp renders orthographic views only: the scene's [camera] has \
             projection = \"perspective\" (fov_y_deg = {fov_y_deg}); use --renderer slice3d"
        )));
    }
    let view = scene.camera.view(scene.image.width, scene.image.height);
    let (lo, hi) = input.volume.bounds();
    let behind = (0..8).any(|c| {
        let p = std::array::from_fn(|a| if c >> a & 1 == 0 { lo[a] } else { hi[a] });
        view.to_camera(p)[2] < 0.0
    });
    if behind {
        return Err(Error::Invalid(format!(
            "--renderer shearwarp: the volume of scene {} reaches behind the orthographic eye \
             plane (move camera.eye back along the view direction, or use --renderer slice3d)",
            scene.data.path.display()
        )));
    }
    Ok(())
}

/// Intermediate-image pixels (one per voxel column) per final pixel along
/// the final image's shorter warp axis: below 1 the warp magnifies, each
/// voxel column's composited colour is spread bilinearly over more than
/// one final pixel, and hard edges blur over a voxel (lobster-view at 0.59:
/// RMSE 4.8/255 against slice3d's 0.70; docs/experiments/shearwarp.md).
pub fn warp_scale(input: &VolumeInput) -> f64 {
    let scene = &input.scene;
    let view = scene.camera.view(scene.image.width, scene.image.height);
    let m = Factor::new(&view, &input.volume).warp_matrix;
    m.x_axis.length().min(m.y_axis.length())
}

/// Renders `input` (prepare the view's encoding + frame); the stats hold
/// both times.
pub fn render(input: &VolumeInput, opts: &ShearWarpOptions) -> Result<(Image, SliceStats)> {
    check(input, opts)?;
    let prep = prepare_for_view(input);
    let (img, mut st) = render_prepared(input, &prep, opts)?;
    st.time_prepare_s = prep.time_s;
    Ok((img, st))
}

/// Renders one frame with the encodings from [`prepare`] (built for this
/// input's volume and transfer function).
pub fn render_prepared(
    input: &VolumeInput,
    prep: &Prepared,
    opts: &ShearWarpOptions,
) -> Result<(Image, SliceStats)> {
    check(input, opts)?;
    let vol = &*input.volume;
    if prep.dims != vol.dims {
        return Err(Error::Invalid(format!(
            "internal: shear-warp encodings of a {:?} volume given a {:?} one",
            prep.dims, vol.dims
        )));
    }
    let start = Instant::now();
    let scene = &input.scene;
    let tf = &scene.transfer;
    let (w, h) = (scene.image.width, scene.image.height);
    let view = scene.camera.view(w, h);
    let f = Factor::new(&view, vol);
    let own;
    let lut = if prep.lut.0 == *tf && prep.lut.1 == input.range {
        &prep.lut.2
    } else {
        own = Lut::new(tf, input.range);
        &own
    };
    let k = (f.delta / tf.unit_distance) as f32;
    let (full, half) = (lut.baked(k), lut.baked(0.5 * k));
    let steps = slice_steps(&f);
    let mut inter = vec![[0.0f32; 4]; f.size[0] * f.size[1]];
    let tables = Tables {
        lut,
        full: &full,
        half: &half,
    };
    let c = f.principal;
    let (mut counts, texture_bytes) = match &prep.encoded {
        Encoded::U8(e) => composite_all(axis_of(e, c, lut)?, &tables, &steps, opts, &f, &mut inter),
        Encoded::U16(e) => {
            composite_all(axis_of(e, c, lut)?, &tables, &steps, opts, &f, &mut inter)
        }
        Encoded::I16(e) => {
            composite_all(axis_of(e, c, lut)?, &tables, &steps, opts, &f, &mut inter)
        }
        Encoded::F32(e) => {
            composite_all(axis_of(e, c, lut)?, &tables, &steps, opts, &f, &mut inter)
        }
    };
    let mut image = Image::new(w, h);
    let bg = scene.image.background.map(|x| x as f32);
    counts.covered = warp::warp(&f, &inter, &mut image, bg);
    let mut st = SliceStats {
        renderer: "shearwarp",
        voxels: vol.len(),
        slices: f.n[2] as u64,
        slice_spacing: f.delta,
        slicing_axis: Some(c),
        classify: Some(Classify::Post),
        order: Some(Order::FrontToBack),
        ert_threshold: opts.ert as f64,
        ert_error_bound: SliceStats::ert_bound(opts.ert, Order::FrontToBack, tf),
        threads: rayon::current_num_threads(),
        texture_bytes,
        ..Default::default()
    };
    st.add_counts(&counts);
    st.time_render_s = start.elapsed().as_secs_f64();
    Ok((image, st))
}

/// The frame's classification tables.
struct Tables<'a> {
    lut: &'a Lut,
    full: &'a [[f32; 4]],
    half: &'a [[f32; 4]],
}

/// Composites all slices into `inter` (scanlines in parallel); returns the
/// counts and the bytes of the encoding used.
fn composite_all<T: Texel>(
    rle: &AxisRle<T>,
    t: &Tables<'_>,
    steps: &[composite::SliceStep],
    opts: &ShearWarpOptions,
    f: &Factor,
    inter: &mut [[f32; 4]],
) -> (SampleCounts, u64) {
    let s = Slices {
        rle,
        lut: t.lut,
        full: t.full,
        half: t.half,
        ert: opts.ert,
        empty_skip: opts.empty_skip,
    };
    let w = f.size[0];
    let n = inter
        .par_chunks_mut(w * composite::BAND)
        .enumerate()
        .map_init(Vec::new, |next, (b, rows)| {
            crate::base::cancel::checkpoint();
            band(&s, steps, b * composite::BAND, w, rows, next)
        })
        .reduce(SampleCounts::default, SampleCounts::merge);
    (n, rle.bytes())
}
