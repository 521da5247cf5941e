//! Scan conversion: for each pixel centre a tet covers, the ray's entry and
//! exit depth, the scalar at both, and one integrated ray segment.
//!
//! A ray is inside a tet exactly where it is inside all four face
//! half-spaces `sigma n · p <= sigma h`. Along the ray `o + τ d`, a face with
//! `sigma n · d > 0` bounds `τ` from above (the ray leaves through it), one
//! with `sigma n · d < 0` from below (the ray enters through it), and one with
//! `n · d = 0` (seen exactly edge-on) either contains the whole ray or none of
//! it. So `τ_in = max` over entering faces, `τ_out = min` over leaving faces,
//! and the pixel is covered iff `τ_in < τ_out`: no special cases for the
//! silhouette's shape, and no division by zero.

use super::fastmath::{ceil_i, fclamp, floor_i, fmax, fmin};
use super::project::PerspRays;
use super::setup::TetSetup;
pub use super::target::{Pending, ScanCounts, ScanTarget};
use crate::base::Rect;

/// Pixel range `[i0, i1] x [j0, j1]` (inclusive) whose centres lie in the
/// bounding box of `pts` (continuous pixel coordinates), clipped to `clip`.
/// `None` if no pixel centre is inside.
#[inline(always)]
pub fn covered_pixels(pts: &[[f32; 2]; 4], clip: Rect) -> Option<(u32, u32, u32, u32)> {
    let (mut xl, mut xh, mut yl, mut yh) = (
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
    );
    for p in pts {
        xl = xl.min(p[0]);
        xh = xh.max(p[0]);
        yl = yl.min(p[1]);
        yh = yh.max(p[1]);
    }
    box_pixels([xl, xh, yl, yh], clip)
}

/// Pixel range `[i0, i1] x [j0, j1]` (inclusive) whose centres lie in the
/// box `[xl, xh] x [yl, yh]` (continuous pixel coordinates), clipped to
/// `clip`. `None` if no pixel centre is inside (or the box is empty or NaN).
#[inline(always)]
pub fn box_pixels([xl, xh, yl, yh]: [f32; 4], clip: Rect) -> Option<(u32, u32, u32, u32)> {
    // Centre i + 0.5 in [xl, xh]  <=>  i in [ceil(xl - 0.5), floor(xh - 0.5)].
    // Clamping to the clip rectangle (padded by one) first keeps the integer
    // conversions in range, NaN included (it fails every comparison below).
    if !(xl <= xh && yl <= yh) {
        return None;
    }
    let lim = |v: f32, lo: u32, hi: u32| fclamp(v, lo as f32 - 1.0, hi as f32 + 1.0);
    let i0 = ceil_i(lim(xl - 0.5, clip.x0, clip.x1)).max(clip.x0 as i64);
    let i1 = floor_i(lim(xh - 0.5, clip.x0, clip.x1)).min(clip.x1 as i64 - 1);
    let j0 = ceil_i(lim(yl - 0.5, clip.y0, clip.y1)).max(clip.y0 as i64);
    let j1 = floor_i(lim(yh - 0.5, clip.y0, clip.y1)).min(clip.y1 as i64 - 1);
    if i0 > i1 || j0 > j1 {
        return None;
    }
    Some((i0 as u32, i1 as u32, j0 as u32, j1 as u32))
}

/// Whether a ray is outside the half-space of a face seen exactly edge-on
/// (the face plane contains the ray direction), given `v` = signed distance
/// of the ray from the plane in the outward direction and `(a, b)` the
/// outward normal's screen components.
///
/// A ray that lies *in* the plane (`v == 0`, e.g. a pixel centre exactly on
/// the projection of a face or an edge parallel to the view) touches both
/// tets sharing that face; counting it for both would add its light twice.
/// So ties are broken by symbolic perturbation, as rasterisers' fill rules
/// do: the ray is moved by `(-ε, -ε²)`, and it is inside iff the outward normal
/// points away from that move (`a > 0`, or `a == 0` and `b > 0`). The two
/// tets sharing the face have opposite normals, so exactly one gets the ray.
#[inline(always)]
fn outside_edge_on(v: f32, a: f32, b: f32) -> bool {
    v > 0.0 || (v == 0.0 && (a < 0.0 || (a == 0.0 && b <= 0.0)))
}

/// A tet's faces as depth planes `Z = a X + b Y + c` in screen space
/// (orthographic): at most three entering and three leaving (unused slots
/// at `-inf` / `+inf`), and the faces seen exactly edge-on as half-planes.
struct OrthoPlanes {
    ent: [[f32; 3]; 3],
    ext: [[f32; 3]; 3],
    edge: [[f32; 3]; 4],
    /// Entering, leaving and edge-on faces.
    ne: usize,
    nx: usize,
    nedge: usize,
}

impl OrthoPlanes {
    /// `None` when the tet has no entering or no leaving face (or more
    /// than three of either: numerically flat), so covers no pixel.
    #[inline(always)]
    fn new(t: &TetSetup) -> Option<OrthoPlanes> {
        // The coefficients are odd/odd ratios of (n, h), so both tets
        // sharing a face get identical ones.
        let mut p = OrthoPlanes {
            ent: [[0.0, 0.0, f32::NEG_INFINITY]; 3],
            ext: [[0.0, 0.0, f32::INFINITY]; 3],
            edge: [[0.0f32; 3]; 4],
            ne: 0,
            nx: 0,
            nedge: 0,
        };
        for f in &t.faces {
            let [x, y, z] = f.n;
            if z == 0.0 {
                // Edge-on: inside iff sigma (n_x X + n_y Y) <= sigma h.
                p.edge[p.nedge] = [f.sigma * x, f.sigma * y, f.sigma * f.h];
                p.nedge += 1;
                continue;
            }
            let plane = [-x / z, -y / z, f.h / z];
            if f.sigma * z > 0.0 {
                if p.nx == 3 {
                    return None;
                }
                p.ext[p.nx] = plane;
                p.nx += 1;
            } else {
                if p.ne == 3 {
                    return None;
                }
                p.ent[p.ne] = plane;
                p.ne += 1;
            }
        }
        (p.ne > 0 && p.nx > 0).then_some(p)
    }

    /// Row set-up: the planes' `b y + c` at the row's `y`, entering then
    /// leaving. (Written out: `array::map` is not always inlined here.)
    #[inline(always)]
    fn row(&self, y: f32) -> ([f32; 3], [f32; 3]) {
        let (ent, ext) = (&self.ent, &self.ext);
        (
            [
                ent[0][1] * y + ent[0][2],
                ent[1][1] * y + ent[1][2],
                ent[2][1] * y + ent[2][2],
            ],
            [
                ext[0][1] * y + ext[0][2],
                ext[1][1] * y + ext[1][2],
                ext[2][1] * y + ext[2][2],
            ],
        )
    }
}

/// The ray segment of one pixel through a tet: `(z_in, z_out, s_in, s_out)`.
pub type PixelSegment = (f32, f32, f32, f32);

/// The segment of pixel `(i, j)` through the tet `t` (orthographic), or
/// `None` if its centre is not covered: [`scan_ortho`]'s test and
/// values for that pixel, bit for bit (the binning computes the segments
/// of cells with one pixel centre with it).
#[inline(always)]
pub fn ortho_segment(t: &TetSetup, i: u32, j: u32) -> Option<PixelSegment> {
    let p = OrthoPlanes::new(t)?;
    let y = j as f32 + 0.5;
    let (re, rx) = p.row(y);
    let s_row = t.s0 + t.grad[1] * (y - t.v0[1]);
    pixel_test(t, &p, (re, rx, s_row), i, y)
}

/// Scans one tet in screen space (orthographic), over the pixels of
/// `range = (i0, i1, j0, j1)`.
#[inline]
pub fn scan_ortho(t: &TetSetup, range: (u32, u32, u32, u32), out: &mut ScanTarget) {
    // Scalars are clamped to the cell's range: its segments stay in one
    // transfer-function piece if the range does.
    out.cell_piece = out.tf.single_piece(t.s_min, t.s_max);
    let Some(p) = OrthoPlanes::new(t) else {
        return;
    };
    let (i0, i1, j0, j1) = range;
    if i0 > i1 || j0 > j1 {
        return;
    }
    if i0 == i1 && j0 == j1 {
        // One pixel centre in the box (most cells of a large mesh): the
        // per-pixel test alone, without the row's span or the box kernel's
        // set-up. The same expressions, so the same segment bit for bit.
        let y = j0 as f32 + 0.5;
        let (re, rx) = p.row(y);
        let s_row = t.s0 + t.grad[1] * (y - t.v0[1]);
        if let Some(seg) = pixel_test(t, &p, (re, rx, s_row), i0, y) {
            emit(out, i0, j0, seg);
        }
        return;
    }
    let (ent, ext, ne, nx) = (&p.ent, &p.ext, p.ne, p.nx);
    #[cfg(target_arch = "x86_64")]
    if out.simd
        && p.nedge == 0
        && u64::from(i1 - i0 + 1) * u64::from(j1 - j0 + 1)
            <= u64::from(super::scan_box::MAX_BOX_PIXELS)
    {
        // SAFETY: `simd` is set only where the CPU has AVX2; the box is
        // inside the tile and small enough.
        unsafe { super::scan_box::scan_box_avx2(t, ent, ext, range, out) };
        return;
    }
    let x_max = i1 as f32 + 1.0;
    for j in j0..=j1 {
        let y = j as f32 + 0.5;
        let (re, rx) = p.row(y);
        // The row's covered span: z_in(X) < z_out(X) holds iff every entering
        // plane lies in front of every leaving one, a linear inequality in X per
        // pair. The span is widened by a pixel and every pixel is still tested
        // exactly below, so rounding here can cost time but never coverage.
        let (mut lo, mut hi) = (f32::NEG_INFINITY, f32::INFINITY);
        for e in 0..ne {
            for k in 0..nx {
                let da = ent[e][0] - ext[k][0];
                let rhs = rx[k] - re[e];
                // The per-pixel test rounds `a x + r` on both sides: widen the
                // bound by that rounding (relative to the terms' magnitude,
                // over the slope difference), so the span never drops a pixel
                // the exact test would keep. Near-parallel planes get a huge
                // slack and so no narrowing at all.
                let m = (ent[e][0].abs() + ext[k][0].abs()) * x_max + re[e].abs() + rx[k].abs();
                let inv = 1.0 / da;
                let slack = 8.0 * f32::EPSILON * m * inv.abs() + 1e-3;
                if da > 0.0 {
                    hi = fmin(hi, rhs * inv + slack);
                } else if da < 0.0 {
                    lo = fmax(lo, rhs * inv - slack);
                } else if !(rhs > 0.0) {
                    hi = f32::NEG_INFINITY;
                }
            }
        }
        if !(lo <= hi) {
            continue;
        }
        let first = ceil_i(fclamp(lo - 0.5, -1.0, 1e9)).max(i0 as i64);
        let last = floor_i(fclamp(hi - 0.5, -1.0, 1e9)).min(i1 as i64);
        if first > last {
            continue;
        }
        let dy = y - t.v0[1];
        let s_row = t.s0 + t.grad[1] * dy;
        for i in first as u32..=last as u32 {
            if let Some(seg) = pixel_test(t, &p, (re, rx, s_row), i, y) {
                emit(out, i, j, seg);
            }
        }
    }
}

/// The per-pixel test and segment of [`scan_ortho`]: pixel column `i` of
/// a row at `y` whose planes were evaluated there (`re`, `rx`: `b y + c`
/// of the entering and leaving planes; `s_row`: the scalar at `(v0.x, y)`).
#[inline(always)]
fn pixel_test(
    t: &TetSetup,
    p: &OrthoPlanes,
    (re, rx, s_row): ([f32; 3], [f32; 3], f32),
    i: u32,
    y: f32,
) -> Option<PixelSegment> {
    let (ent, ext) = (&p.ent, &p.ext);
    let x = i as f32 + 0.5;
    // Depth is measured from the eye plane: nothing behind it is seen.
    let z_in = fmax(
        fmax(
            fmax(ent[0][0] * x + re[0], ent[1][0] * x + re[1]),
            ent[2][0] * x + re[2],
        ),
        0.0,
    );
    let z_out = fmin(
        fmin(ext[0][0] * x + rx[0], ext[1][0] * x + rx[1]),
        ext[2][0] * x + rx[2],
    );
    if !(z_in < z_out) {
        return None;
    }
    if p.edge[..p.nedge]
        .iter()
        .any(|e| outside_edge_on(e[0] * x + e[1] * y - e[2], e[0], e[1]))
    {
        return None;
    }
    let s_xy = s_row + t.grad[0] * (x - t.v0[0]);
    let s_in = fclamp(s_xy + t.grad[2] * (z_in - t.v0[2]), t.s_min, t.s_max);
    let s_out = fclamp(s_xy + t.grad[2] * (z_out - t.v0[2]), t.s_min, t.s_max);
    Some((z_in, z_out, s_in, s_out))
}

/// Emits pixel `(i, j)`'s covered segment (orthographic: its length is
/// `z_out - z_in`).
#[inline(always)]
fn emit(out: &mut ScanTarget, i: u32, j: u32, (z_in, z_out, s_in, s_out): PixelSegment) {
    out.counts.pixels_tested += 1;
    out.emit(i, j, z_in, z_out, s_in, s_out, z_out - z_in);
}

/// Scans one tet in the camera frame (perspective): the ray of pixel `(X, Y)`
/// is `τ d`, `d = (dx, dy, 1)`; the face bound is `τ = h / (n · d)`; depth
/// along the ray is `τ |d|`. `τ >= 0` clips everything behind the eye.
#[inline]
pub fn scan_persp(
    t: &TetSetup,
    rays: &PerspRays,
    range: (u32, u32, u32, u32),
    out: &mut ScanTarget,
) {
    // Scalars are clamped to the cell's range: its segments stay in one
    // transfer-function piece if the range does.
    out.cell_piece = out.tf.single_piece(t.s_min, t.s_max);
    let (i0, i1, j0, j1) = range;
    for j in j0..=j1 {
        let y = j as f32 + 0.5;
        for i in i0..=i1 {
            let x = i as f32 + 0.5;
            out.counts.pixels_tested += 1;
            let d = rays.dir(x, y);
            let (mut t_in, mut t_out) = (0.0f32, f32::INFINITY);
            let mut inside = true;
            for f in &t.faces {
                let den = f.n[0] * d[0] + f.n[1] * d[1] + f.n[2];
                let out_den = f.sigma * den;
                if out_den > 0.0 {
                    t_out = t_out.min(f.h / den);
                } else if out_den < 0.0 {
                    t_in = t_in.max(f.h / den);
                } else if outside_edge_on(-f.sigma * f.h, f.sigma * f.n[0], f.sigma * f.n[1]) {
                    inside = false;
                }
            }
            if !inside || !(t_in < t_out) {
                continue;
            }
            let len_d = (d[0] * d[0] + d[1] * d[1] + 1.0).sqrt();
            let s_in = t.scalar_at([d[0] * t_in, d[1] * t_in, t_in]);
            let s_out = t.scalar_at([d[0] * t_out, d[1] * t_out, t_out]);
            out.emit(
                i,
                j,
                t_in * len_d,
                t_out * len_d,
                s_in,
                s_out,
                (t_out - t_in) * len_d,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::Segment;
    use crate::render::cell::integrate::{Integrator, PreparedTf};
    use crate::render::cell::list::SegmentLists;
    use crate::render::cell::setup::setup_tet;
    use crate::scene::transfer::TransferFunction;
    use proptest::prelude::*;

    /// Scans tets into fresh lists of `tile` (no partial composition, so
    /// every segment stays), by the box kernel or by the scalar span scan.
    fn scan_all(
        tets: &[([[f32; 3]; 4], [f32; 4])],
        tile: Rect,
        simd: bool,
    ) -> (Vec<Vec<Segment>>, ScanCounts) {
        let tf = PreparedTf::new(&TransferFunction::from_rows(
            &[[0.0, 1.0, 0.2, 0.1, 0.3], [1.0, 0.1, 0.4, 1.0, 0.9]],
            5.0,
        ));
        let mut lists = SegmentLists::new(tile.width(), tile.height());
        let mut counts = ScanCounts::default();
        let mut pending = crate::render::cell::scan::Pending::default();
        let mut t = ScanTarget::new(
            &mut lists,
            tile,
            &tf,
            Integrator::Exact,
            false,
            false,
            &mut counts,
            &mut pending,
        );
        t.simd = simd;
        for (k, (p, s)) in tets.iter().enumerate() {
            let base = 4 * k as u32;
            let Some(setup) = setup_tet([base, base + 1, base + 2, base + 3], p, s) else {
                continue;
            };
            let pts = p.map(|v| [v[0], v[1]]);
            if let Some(range) = covered_pixels(&pts, tile) {
                scan_ortho(&setup, range, &mut t);
            }
        }
        t.flush();
        (lists.lists().to_vec(), counts)
    }

    fn bits(l: &[Vec<Segment>]) -> Vec<Vec<[u32; 6]>> {
        l.iter()
            .map(|v| v.iter().map(Segment::bits).collect())
            .collect()
    }

    /// A coordinate: anywhere, or exactly on a pixel centre or a pixel edge
    /// (ties between the planes of neighbouring cells).
    fn coord(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
        prop_oneof![
            lo..hi,
            (lo as i32..hi as i32).prop_map(|i| i as f32 + 0.5),
            (lo as i32..hi as i32).prop_map(|i| i as f32),
        ]
    }

    fn vertex() -> impl Strategy<Value = [f32; 3]> {
        (coord(-6.0, 40.0), coord(-6.0, 30.0), 0.5f32..20.0).prop_map(|(x, y, z)| [x, y, z])
    }

    fn tet() -> impl Strategy<Value = ([[f32; 3]; 4], [f32; 4])> {
        (
            [vertex(), vertex(), vertex(), vertex()],
            [0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0],
        )
    }

    proptest! {
        /// The box kernel makes the scalar span scan's segments, bit for
        /// bit, and the same counts (the virtual clock must not depend on
        /// the CPU), for tets clipped by the tile's edges too.
        #[test]
        fn box_kernel_equals_span_scan(tets in proptest::collection::vec(tet(), 1..12)) {
            if !std::arch::is_x86_feature_detected!("avx2") {
                return Ok(());
            }
            let tile = Rect { x0: 3, y0: 2, x1: 35, y1: 27 };
            let (a, ca) = scan_all(&tets, tile, true);
            let (b, cb) = scan_all(&tets, tile, false);
            prop_assert_eq!(bits(&a), bits(&b));
            prop_assert_eq!(ca.pixels_tested, cb.pixels_tested);
            prop_assert_eq!(ca.segments_generated, cb.segments_generated);
            prop_assert_eq!(ca.pixels_tested, ca.segments_generated);
        }
    }
}
