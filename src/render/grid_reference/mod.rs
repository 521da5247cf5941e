//! The reference renderer for regular grids: the f64 oracle the slicers are
//! measured against. It shares nothing with them but the scene,
//! transfer-function and volume types.
//!
//! # What it computes
//!
//! Per pixel, the ray `r(t) = o + t d` of [`View::ray`](crate::scene::View::ray)
//! (`d` unit, `t >= 0`) through the trilinear field of the volume, clipped to
//! the volume box and walked voxel cell by voxel cell ([`walk`], 3D DDA).
//! Inside a cell the field along the ray is a cubic in `t` ([`cubic`]); it
//! is cut where it crosses a kink of the transfer function (its control
//! points, and where the opacity reaches the clamp `1 - 1e-6`), and each
//! kink-free piece is integrated by adaptive Gauss–Legendre collocation
//! ([`quadrature`]) of the model of `scene.md`:
//!
//! ```text
//!   tau(s) = -ln(1 - min(opacity(s), 1 - 1e-6)) / unit_distance
//!   C = ∫ c(s(t)) tau(s(t)) T(t) dt,  T(t) = exp(-∫_0^t tau),  A = 1 - T(end)
//!   pixel = C + (1 - A) background
//! ```
//!
//! with a per-pixel error budget `tol` (default 1e-6). A cell whose eight
//! corner values span a scalar interval of zero opacity is skipped: the
//! trilinear field inside a cell stays within its corners' min and max, so
//! that stretch adds nothing (exactly). A ray stops when `T < 1e-12`.
//!
//! All f64; rows in parallel (rayon); each pixel is computed by the same
//! sequential code, so the image does not depend on the thread count.

pub mod cubic;
pub mod quadrature;
pub mod walk;

#[cfg(test)]
pub(crate) mod tests;

use std::time::Instant;

use rayon::prelude::*;

use crate::image::Image;
use crate::render::VolumeInput;
use crate::scene::transfer::OPACITY_MAX;
use crate::scene::TransferFunction;

use cubic::Cubic;
use quadrature::{Piece, QuadCounters};

/// A ray stops once its transmittance is below this.
pub const T_MIN: f64 = 1e-12;

/// Options of the grid reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridReferenceOptions {
    /// Absolute error budget per pixel channel (raised to 1e-14 if smaller).
    pub tolerance: f64,
}

impl Default for GridReferenceOptions {
    fn default() -> Self {
        GridReferenceOptions { tolerance: 1e-6 }
    }
}

/// What the grid reference did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct GridReferenceStats {
    /// Rays cast (one per pixel).
    pub rays: u64,
    /// Rays that met the volume box.
    pub rays_hit: u64,
    /// Cell stretches walked.
    pub cells_visited: u64,
    /// Of those, skipped because their corners' scalar range is transparent.
    pub cells_skipped_empty: u64,
    /// Kink-free pieces integrated.
    pub quadrature_pieces: u64,
    /// Applications of the 8-node rule.
    pub quadrature_rules: u64,
    /// Intervals accepted at the depth limit without meeting the tolerance.
    pub quadrature_depth_limited: u64,
    /// The tolerance used.
    pub tolerance: f64,
    /// Wall time, seconds.
    pub time_s: f64,
    /// Rayon threads available.
    pub threads: usize,
}

#[derive(Default)]
struct Counters {
    hit: u64,
    cells: u64,
    empty: u64,
    pieces: u64,
    quad: QuadCounters,
}

/// The scalars where the transfer function has a kink: its control points,
/// and on each linear piece the `s` where the opacity reaches the clamp.
fn kinks(tf: &TransferFunction) -> Vec<f64> {
    let mut k: Vec<f64> = tf.points.iter().map(|p| p.s).collect();
    for w in tf.points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (lo, hi) = (a.opacity.min(b.opacity), a.opacity.max(b.opacity));
        if b.s > a.s && lo < OPACITY_MAX && hi > OPACITY_MAX {
            k.push(a.s + (b.s - a.s) * (OPACITY_MAX - a.opacity) / (b.opacity - a.opacity));
        }
    }
    k.sort_by(f64::total_cmp);
    k.dedup();
    k
}

struct Tracer<'a> {
    input: &'a VolumeInput,
    tf: &'a TransferFunction,
    kinks: Vec<f64>,
    /// `tol / L`, L the box diagonal in world units.
    density: f64,
}

impl Tracer<'_> {
    fn trace(&self, o: [f64; 3], d: [f64; 3], n: &mut Counters) -> Piece {
        let vol = &*self.input.volume;
        let g0 = std::array::from_fn(|a| (o[a] - vol.origin[a]) / vol.spacing[a]);
        // Grid units per unit of t; t stays the world distance along the ray.
        let dg = std::array::from_fn(|a| d[a] / vol.spacing[a]);
        let mut acc = Piece::EMPTY;
        let mut cuts = Vec::with_capacity(16);
        let tf = self.tf;
        let ud = tf.unit_distance;
        let cells = walk::walk(g0, dg, vol.dims, |st| {
            let [i, j, k] = st.cell;
            let mut s = [[[0.0; 2]; 2]; 2];
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for (dk, plane) in s.iter_mut().enumerate() {
                for (dj, row) in plane.iter_mut().enumerate() {
                    for (di, v) in row.iter_mut().enumerate() {
                        let raw = vol.get(i + di as u64, j + dj as u64, k + dk as u64) as f64;
                        *v = self.input.normalise(raw);
                        lo = lo.min(*v);
                        hi = hi.max(*v);
                    }
                }
            }
            if tf.max_opacity_in(lo, hi) == 0.0 {
                n.empty += 1;
                return true;
            }
            let cubic = Cubic::trilinear(&s, st.u0, st.du);
            let len = st.t1 - st.t0;
            cuts.clear();
            cuts.push(0.0);
            cubic.crossings(len, &self.kinks, &mut cuts);
            cuts.push(len);
            cuts.sort_by(f64::total_cmp);
            let field = |tau: f64| {
                let (c, op) = tf.eval(cubic.eval(tau));
                (c, -(1.0 - op.min(OPACITY_MAX)).ln() / ud)
            };
            for w in cuts.windows(2) {
                n.pieces += 1;
                let p = quadrature::integrate(&field, w[0], w[1], acc.t, self.density, &mut n.quad);
                acc = acc.over(p);
            }
            acc.t >= T_MIN
        });
        if cells > 0 {
            n.hit += 1;
        }
        n.cells += cells;
        acc
    }
}

/// Renders `input` with the grid reference.
pub fn render(input: &VolumeInput, opts: &GridReferenceOptions) -> (Image, GridReferenceStats) {
    let start = Instant::now();
    let scene = &input.scene;
    let (w, h) = (scene.image.width, scene.image.height);
    let view = scene.camera.view(w, h);
    let bg = scene.image.background;
    let tol = if opts.tolerance.is_nan() {
        1e-6
    } else {
        opts.tolerance.max(1e-14)
    };
    let (lo, hi) = input.volume.bounds();
    let diag = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
    let tracer = Tracer {
        input,
        tf: &scene.transfer,
        kinks: kinks(&scene.transfer),
        density: tol / diag.max(f64::MIN_POSITIVE),
    };
    let rows: Vec<(Vec<[f32; 4]>, Counters)> = (0..h)
        .into_par_iter()
        .map(|j| {
            crate::base::cancel::checkpoint();
            let mut n = Counters::default();
            let row = (0..w)
                .map(|i| {
                    let (o, d) = view.ray(i, j);
                    let acc = tracer.trace(o, d, &mut n);
                    [
                        (acc.c[0] + acc.t * bg[0]) as f32,
                        (acc.c[1] + acc.t * bg[1]) as f32,
                        (acc.c[2] + acc.t * bg[2]) as f32,
                        (1.0 - acc.t) as f32,
                    ]
                })
                .collect();
            (row, n)
        })
        .collect();
    let mut image = Image::new(w, h);
    image.pixels.clear();
    let mut st = GridReferenceStats {
        rays: w as u64 * h as u64,
        tolerance: tol,
        threads: rayon::current_num_threads(),
        ..Default::default()
    };
    for (row, n) in rows {
        image.pixels.extend(row);
        st.rays_hit += n.hit;
        st.cells_visited += n.cells;
        st.cells_skipped_empty += n.empty;
        st.quadrature_pieces += n.pieces;
        st.quadrature_rules += n.quad.rules;
        st.quadrature_depth_limited += n.quad.depth_limited;
    }
    st.time_s = start.elapsed().as_secs_f64();
    (image, st)
}
