//! Object-aligned texture slicing in software (the 2D-texture method of
//! `slice-lod-memory.txt`), with its per-slice level of detail ([`lod`]).
//!
//! The slices are the volume's own sample planes perpendicular to the axis
//! `a` most parallel to the view (`argmax_a |f_a|`, `f` the view direction,
//! or for perspective the direction from the eye to the volume's centre).
//! A pixel's ray `G0 + t dG` (grid coordinates) meets plane `g_a = m` at
//! `t_m = (m - G0_a) / dG_a`; there the slice is read bilinearly (the plane
//! is a grid plane, so this equals the trilinear field there) and the
//! sample is classified. Consecutive planes are `spacing_a` apart along the
//! axis, so along the ray the sample distance is the oblique path length
//! `δ = spacing_a / |d_a|` (`d` the unit ray direction: `δ = Δ / cos`), and
//! the opacity is corrected with it: `α = 1 - (1 - o)^(δ / unit_distance)`.
//!
//! When the view turns past 45° between two axes the slicing axis changes
//! and the samples jump from one set of planes to another: the image jumps
//! (shown by a test, not hidden). Compositing and classification are as in
//! `slice3d` (front to back with ERT, or back to front with `(1, 1 - A_s)`;
//! post or pre). With `--lod D` each slice is read at its level
//! `L_x = floor(log2(d_x / D))`, `d_x` the distance from the eye to the
//! slice's plane; the texture memory of the frame is the bytes of the
//! slices actually sampled, at their level.

pub mod lod;
pub mod stack;

#[cfg(test)]
mod tests;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::image::Image;
use crate::render::slicing::{correct_opacity, Classify, Lut, Order, SampleCounts, SliceStats};
use crate::render::VolumeInput;
use crate::scene::Projection;

use stack::{plane_axes, Level, TILE};

/// Options of the 2D slicer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slice2dOptions {
    /// Post- (default) or pre-classification.
    pub classify: Classify,
    /// Front to back with ERT (default) or back to front.
    pub order: Order,
    /// ERT threshold in `(0, 1]`; 1 = off.
    pub ert: f32,
    /// LOD distance `D` (world units), or `None` for full resolution.
    pub lod: Option<f64>,
    /// Skip samples in transparent tiles (default on).
    pub empty_skip: bool,
}

impl Default for Slice2dOptions {
    fn default() -> Self {
        Slice2dOptions {
            classify: Classify::Post,
            order: Order::FrontToBack,
            ert: 0.99,
            lod: None,
            empty_skip: true,
        }
    }
}

/// One slice: its levels `0..=L` and per level the tiles' opacity flags.
struct Slice<const C: usize> {
    levels: Vec<Level<C>>,
    opaque: Vec<Vec<bool>>,
    used: AtomicBool,
}

/// The slicing axis for the view: largest component of the view direction
/// (perspective: towards the volume's centre).
pub fn slicing_axis(input: &VolumeInput) -> usize {
    let view = input.scene.camera.view(1, 1);
    let dir = match input.scene.camera.projection {
        Projection::Orthographic { .. } => view.forward,
        Projection::Perspective { .. } => {
            let (lo, hi) = input.volume.bounds();
            std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]) - view.eye[a])
        }
    };
    (0..3)
        .max_by(|&x, &y| dir[x].abs().total_cmp(&dir[y].abs()))
        .unwrap_or(2)
}

/// Renders `input` with the 2D slicer.
pub fn render(input: &VolumeInput, opts: &Slice2dOptions) -> Result<(Image, SliceStats)> {
    if !(opts.ert > 0.0 && opts.ert <= 1.0) {
        return Err(Error::Invalid(format!(
            "--ert must be in (0, 1], got {}",
            opts.ert
        )));
    }
    if let Some(d) = opts.lod {
        if !(d > 0.0 && d.is_finite()) {
            return Err(Error::Invalid(format!(
                "--lod must be a finite distance > 0, got {d}"
            )));
        }
    }
    match opts.classify {
        Classify::Post => render_c::<1>(input, opts),
        Classify::Pre => render_c::<4>(input, opts),
        Classify::Preint => Err(Error::Invalid(
            "--classify preint is slice3d's (pre-integrated sample pairs); slice2d takes \
             post or pre"
                .into(),
        )),
    }
}

fn render_c<const C: usize>(
    input: &VolumeInput,
    opts: &Slice2dOptions,
) -> Result<(Image, SliceStats)> {
    let t_prep = Instant::now();
    let scene = &input.scene;
    let vol = &*input.volume;
    let tf = &scene.transfer;
    let lut = Lut::new(tf, input.range);
    let a = slicing_axis(input);
    let (ua, va) = plane_axes(a);
    let view = scene.camera.view(scene.image.width, scene.image.height);
    let na = vol.dims[a];
    // Deepest level that keeps >= 2 texels on both in-plane axes.
    let min_side = vol.dims[ua].min(vol.dims[va]);
    let max_level = (63 - min_side.leading_zeros()).saturating_sub(1);
    let levels: Vec<u32> = (0..na)
        .map(|m| match opts.lod {
            None => 0,
            Some(d) => {
                let x = vol.origin[a] + m as f64 * vol.spacing[a];
                lod::level((x - view.eye[a]).abs(), d, max_level)
            }
        })
        .collect();
    // Texel channels: the scalar (post) or (c o, o) (pre).
    let classify = |s: f32| -> [f32; C] {
        let mut t = [0.0; C];
        if C == 1 {
            t[0] = s;
        } else {
            let e = lut.index(s);
            let [r, g, b, _] = lut.sigma[e];
            let o = lut.opacity[e];
            t[0] = r * o;
            t[1] = g * o;
            t[2] = b * o;
            t[C - 1] = o;
        }
        t
    };
    let transparent = |r: [f32; 2]| -> bool {
        if C == 1 {
            lut.transparent(r[0], r[1])
        } else {
            r[1] <= 0.0
        }
    };
    let slices: Vec<Slice<C>> = (0..na)
        .into_par_iter()
        .map(|m| {
            let mut lv = vec![stack::slice(vol, a, m, classify)];
            for _ in 0..levels[m as usize] {
                let next = lv[lv.len() - 1].halve();
                lv.push(next);
            }
            let opaque = lv
                .iter()
                .map(|l| {
                    l.tiles
                        .iter()
                        .map(|&r| !opts.empty_skip || !transparent(r))
                        .collect()
                })
                .collect();
            Slice {
                levels: lv,
                opaque,
                used: AtomicBool::new(false),
            }
        })
        .collect();
    let time_prepare_s = t_prep.elapsed().as_secs_f64();

    let start = Instant::now();
    let (w, h) = (scene.image.width, scene.image.height);
    let bg = scene.image.background.map(|x| x as f32);
    let ud = tf.unit_distance;
    let ert = if opts.order == Order::FrontToBack {
        opts.ert
    } else {
        2.0
    };
    let mut image = Image::new(w, h);
    let counts = image
        .pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .map(|(j, row)| {
            crate::base::cancel::checkpoint();
            let mut n = SampleCounts::default();
            for (i, px) in row.iter_mut().enumerate() {
                let [c0, c1, c2, al] = ray(
                    input, &view, a, &slices, &lut, ud, opts.order, ert, i as u32, j as u32, &mut n,
                );
                let t = 1.0 - al;
                *px = [c0 + t * bg[0], c1 + t * bg[1], c2 + t * bg[2], al];
            }
            n
        })
        .reduce(SampleCounts::default, SampleCounts::merge);

    let bpt = if C == 1 {
        vol.voxels.voxel_type().size() as u64
    } else {
        4
    };
    let mut per_level = vec![0u64; max_level as usize + 1];
    let mut used_bytes = 0;
    for s in &slices {
        if s.used.load(Ordering::Relaxed) {
            let l = s.levels.len() - 1;
            per_level[l] += 1;
            used_bytes += s.levels[l].bytes(bpt);
        }
    }
    while per_level.len() > 1 && per_level[per_level.len() - 1] == 0 {
        per_level.pop();
    }
    let full: u64 = slices.iter().map(|s| s.levels[0].bytes(bpt)).sum();
    let mut st = SliceStats {
        renderer: "slice2d",
        voxels: vol.len(),
        slices: na,
        slice_spacing: vol.spacing[a],
        texture_bytes: used_bytes,
        slicing_axis: Some(a),
        texture_bytes_full: Some(full),
        texture_bytes_three_stacks: Some(3 * vol.len() * bpt),
        lod_d: opts.lod,
        slices_per_level: Some(per_level),
        blocks: slices
            .iter()
            .flat_map(|s| &s.opaque)
            .map(|o| o.len() as u64)
            .sum(),
        blocks_empty: slices
            .iter()
            .flat_map(|s| &s.opaque)
            .map(|o| o.iter().filter(|&&x| !x).count() as u64)
            .sum(),
        classify: Some(opts.classify),
        order: Some(opts.order),
        ert_threshold: opts.ert as f64,
        ert_error_bound: SliceStats::ert_bound(opts.ert, opts.order, tf),
        time_prepare_s,
        threads: rayon::current_num_threads(),
        ..Default::default()
    };
    st.add_counts(&counts);
    st.time_render_s = start.elapsed().as_secs_f64();
    Ok((image, st))
}

/// Bilinear read of level `l` at level-0 coordinates `(u, v)`; returns the
/// texel and the tile index.
#[inline(always)]
fn bilinear<const C: usize>(l: &Level<C>, level: u32, u: f64, v: f64) -> ([f32; C], usize) {
    let s = 1.0 / (1u64 << level) as f64;
    let uu = ((u + 0.5) * s - 0.5).clamp(0.0, (l.n[0] - 1) as f64) as f32;
    let vv = ((v + 0.5) * s - 0.5).clamp(0.0, (l.n[1] - 1) as f64) as f32;
    let iu = (uu as usize).min(l.n[0].saturating_sub(2));
    let iv = (vv as usize).min(l.n[1].saturating_sub(2));
    let (fu, fv) = (uu - iu as f32, vv - iv as f32);
    let iu1 = (iu + 1).min(l.n[0] - 1);
    let iv1 = (iv + 1).min(l.n[1] - 1);
    let g = |x: usize, y: usize| l.texels[y * l.n[0] + x];
    let (p, q, r, t) = (g(iu, iv), g(iu1, iv), g(iu, iv1), g(iu1, iv1));
    let out = std::array::from_fn(|c| {
        let a = p[c] + (q[c] - p[c]) * fu;
        let b = r[c] + (t[c] - r[c]) * fu;
        a + (b - a) * fv
    });
    (out, (iv / TILE) * l.nt[0] + iu / TILE)
}

#[allow(clippy::too_many_arguments)]
fn ray<const C: usize>(
    input: &VolumeInput,
    view: &crate::scene::View,
    a: usize,
    slices: &[Slice<C>],
    lut: &Lut,
    ud: f64,
    order: Order,
    ert: f32,
    i: u32,
    j: u32,
    n: &mut SampleCounts,
) -> [f32; 4] {
    let vol = &*input.volume;
    let (ua, va) = plane_axes(a);
    let (o, d) = view.ray(i, j);
    let g0: [f64; 3] = std::array::from_fn(|x| (o[x] - vol.origin[x]) / vol.spacing[x]);
    let dg: [f64; 3] = std::array::from_fn(|x| d[x] / vol.spacing[x]);
    let hi = vol.dims.map(|x| (x - 1) as f64);
    let mut acc = [0f32; 4];
    if dg[a] == 0.0 {
        return acc; // the ray runs inside a slice plane: no slice is crossed
    }
    let Some((t_in, t_out)) = crate::render::slice3d::planes::clip(g0, dg, hi) else {
        return acc;
    };
    n.covered += 1;
    // Planes m crossed inside [t_in, t_out], in the order of travel.
    let (ga, gb) = (g0[a] + t_in * dg[a], g0[a] + t_out * dg[a]);
    let (lo, hi_m) = (ga.min(gb).ceil().max(0.0), ga.max(gb).floor().min(hi[a]));
    if hi_m < lo {
        return acc;
    }
    let (lo, hi_m) = (lo as i64, hi_m as i64);
    let towards_higher = (dg[a] > 0.0) == (order == Order::FrontToBack);
    let k = ((vol.spacing[a] / d[a].abs()) / ud) as f32;
    let total = (hi_m - lo + 1) as u64;
    let mut done = 0u64;
    for step in 0..=(hi_m - lo) {
        let m = if towards_higher {
            lo + step
        } else {
            hi_m - step
        };
        let t = (m as f64 - g0[a]) / dg[a];
        let (u, v) = (g0[ua] + t * dg[ua], g0[va] + t * dg[va]);
        let sl = &slices[m as usize];
        let level = sl.levels.len() - 1;
        let (tex, tile) = bilinear(&sl.levels[level], level as u32, u, v);
        done += 1;
        // The slice is drawn (resident) whether or not this tile is empty.
        if !sl.used.load(Ordering::Relaxed) {
            sl.used.store(true, Ordering::Relaxed);
        }
        if !sl.opaque[level][tile] {
            n.skipped_empty += 1;
            continue;
        }
        n.taken += 1;
        let [cr, cg, cb, al] = if C == 1 {
            let [r, g, b, sg] = lut.sigma[lut.index(tex[0])];
            let al = 1.0 - (-sg * k).exp();
            [r * al, g * al, b * al, al]
        } else {
            let o = tex[C - 1];
            if o <= 0.0 {
                [0.0; 4]
            } else {
                let al = correct_opacity(o, k);
                let w = al / o;
                [tex[0] * w, tex[1] * w, tex[2] * w, al]
            }
        };
        match order {
            Order::FrontToBack => {
                let w = 1.0 - acc[3];
                acc = [
                    acc[0] + w * cr,
                    acc[1] + w * cg,
                    acc[2] + w * cb,
                    acc[3] + w * al,
                ];
                if acc[3] >= ert {
                    n.skipped_ert += total - done;
                    break;
                }
            }
            Order::BackToFront => {
                let w = 1.0 - al;
                acc = [
                    cr + w * acc[0],
                    cg + w * acc[1],
                    cb + w * acc[2],
                    al + w * acc[3],
                ];
            }
        }
    }
    acc
}
