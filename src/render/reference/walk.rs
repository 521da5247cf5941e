//! Walking one ray through the mesh, tet to tet across shared faces.
//!
//! # Watertight face tests (Plücker side products)
//!
//! All geometry of one ray is done relative to the ray origin `o`: vertex `i`
//! becomes `P_i = p_i - o` (so a mesh far from the world origin loses nothing).
//! The ray is the line through `0` with unit direction `d`. For the edge
//! `(i, j)` with `i < j` (global vertex ids) the side product is
//!
//! ```text
//!   e(i, j) = det(d, P_i, P_j - P_i)      and  e(j, i) = -e(i, j),
//! ```
//!
//! the permuted inner product of the Plücker coordinates of the ray and the
//! edge: its sign says on which side of the edge the ray passes. Because it is
//! always computed from the same two f64 points in the same order, the value
//! for a shared edge is bit-identical in every face and tet that contains it.
//! A face `(i, j, k)` (ids sorted) is *pierced* by the ray's line when
//! `e(i,j), e(j,k), e(k,i)` have no two opposite signs and are not all zero.
//! The pierce point has barycentric weights `(e(j,k), e(k,i), e(i,j)) / W`,
//! from which the ray parameter `t = d · X` and the scalar (linear on the face)
//! follow. Two tets sharing a face therefore agree exactly on whether the ray
//! crosses it, where, and what the scalar is there: the walk has no cracks,
//! and a ray through an edge or a vertex is seen by every face that contains
//! it (zeros are allowed in the sign test).
//!
//! # The walk
//!
//! Inside tet `T`, entered through face `f_in` at `t_cur`, the exit is the
//! pierced face `f != f_in` with the largest `t` (for a line through a convex
//! tet the pierced faces are the entry and the exit; at ties the largest `t`
//! is the far side). The stretch `[t_cur, max(t_exit, t_cur)]` is integrated
//! with the scalar linear between its ends, then the walk crosses to the
//! neighbour, whose entry face is the one pointing back. A ray through an edge
//! circulates around the edge (each tet of the fan has two faces on it, one
//! is excluded as the entry) until it reaches the tet beyond.
//!
//! # Ill-conditioned pierces
//!
//! When the ray runs (nearly) in a face's plane — along an edge, or seeing a
//! face edge-on — that face's three side products are round-off noise: the
//! sign test still gives a *consistent* answer (the walk follows a virtual
//! ray perturbed by round-off, the same in every tet), but the weights put the
//! pierce point somewhere in the triangle, off the ray. Such a pierce is
//! flagged (`on_ray` false: the point is farther than `1e-10 (L_ref + |t|)`
//! from the ray) and the scalar at its `t` is then taken from the tet's own
//! linear function evaluated on the ray (`s_on_ray`), in the tet before and
//! the tet after. With a P1 field the tets sharing a face or an edge agree on
//! it, so the integral stays right even where the transition `t` is vague.
//!
//! # Entries (non-convex meshes)
//!
//! All boundary faces (no neighbour) pierced by the ray at `t >= 0` are found
//! with a BVH, kept when the ray goes *into* their tet there, and sorted by
//! `t`. They are taken in order; one whose `t` lies before the end of the
//! previous walk (minus a tiny `eps_t`) was already passed inside the mesh and
//! is skipped. So every re-entry of a non-convex mesh starts a new walk.
//! If the ray origin is inside the mesh (a perspective eye inside, an
//! orthographic eye plane cutting the mesh) the first walk starts with a
//! location step (below) at `t = 0`.
//!
//! # Recovery: locate-and-clip steps
//!
//! A walk *recovers* when it stalls: no pierced face but the entry, the best
//! exit lies behind `t` (a zero-length step at a degenerate spot led into a
//! tet the ray has already passed), or more than `MAX_ZERO_STEPS` steps in a
//! row made no progress (a ray through a vertex can circle around it). It
//! also checks every exit through a boundary face the same way, since a walk
//! confused at a boundary edge or vertex may leave too early.
//!
//! The step: the tets whose (padded) boxes hold the point `r(t)` are taken
//! from a BVH over all tets; for each, the ray's chord is computed by plain
//! barycentric clipping (each coordinate `lambda_k(t) = a_k + b_k t` by
//! Cramer's rule, chord where all are `>= -1e-12`), which does not depend on
//! noisy sign tests. Among the tets whose chord starts at or before
//! `t + eps_t` and ends after it, the one reaching farthest is taken; its
//! chord `[t, hi]` is integrated with its own linear scalar, and the walk
//! resumes in the neighbour across the face whose coordinate ends the chord.
//! Each such step advances the ray by more than `eps_t`, so recoveries cannot
//! loop. If no tet holds the ray beyond `t`, the ray is outside and the next
//! boundary entry takes over. Successful locations after a stall or an exit
//! are counted as recoveries; flat tets are skipped (they hold no stretch).
//! A walk is abandoned (counted) only after `MAX_RECOVERIES` recoveries or
//! `4 n_tets + 1024` steps, a safety net no test reaches.

use super::bvh::{Aabb, Bvh};
use super::quadrature::{Accum, Integrator, QuadCounters};
use super::T_MIN;
use crate::data::mesh::{FACE_VERTICES, NO_NEIGHBOR};
use crate::data::{Adjacency, TetMesh};

/// Steps in a row that make no progress along the ray before recovering.
const MAX_ZERO_STEPS: u32 = 48;
/// Recoveries of one ray before its walk is abandoned.
const MAX_RECOVERIES: u32 = 1000;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Per-ray counters, summed over the image.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct RayCounters {
    pub rays_hit: u64,
    pub mesh_entries: u64,
    pub origin_inside: u64,
    pub tets_visited: u64,
    pub zero_length_steps: u64,
    pub walk_recoveries: u64,
    pub walks_abandoned: u64,
    pub boundary_hits: u64,
    pub quad: QuadCounters,
}

impl RayCounters {
    pub(crate) fn add(&mut self, o: &RayCounters) {
        self.rays_hit += o.rays_hit;
        self.mesh_entries += o.mesh_entries;
        self.origin_inside += o.origin_inside;
        self.tets_visited += o.tets_visited;
        self.zero_length_steps += o.zero_length_steps;
        self.walk_recoveries += o.walk_recoveries;
        self.walks_abandoned += o.walks_abandoned;
        self.boundary_hits += o.boundary_hits;
        self.quad.pieces += o.quad.pieces;
        self.quad.rules += o.quad.rules;
        self.quad.depth_limited += o.quad.depth_limited;
    }
}

/// Where the ray's line crosses a face: ray parameter and scalar.
#[derive(Debug, Clone, Copy)]
struct Pierce {
    t: f64,
    s: f64,
    /// The pierce point lies on the ray (to round-off). When the ray is
    /// (nearly) in the face's plane the barycentric weights are round-off
    /// noise: the point is somewhere in the triangle, its `t` and `s` are
    /// not the ray's, and the scalar is taken from the tet instead.
    on_ray: bool,
}

/// Everything that does not depend on the ray.
pub(crate) struct Tracer<'a> {
    pts: &'a [[f64; 3]],
    tets: &'a [[u32; 4]],
    nb: &'a [[u32; 4]],
    s: &'a [f64],
    quad: Integrator<'a>,
    /// Boundary faces as `tet << 2 | face`.
    bfaces: Vec<u32>,
    face_bvh: Bvh,
    tet_bvh: Bvh,
    lo: [f64; 3],
    hi: [f64; 3],
    /// Bounding-box diagonal.
    pub l_ref: f64,
}

/// State of one ray.
struct RayCtx<'c> {
    o: [f64; 3],
    d: [f64; 3],
    eps_t: f64,
    acc: Accum,
    ctr: &'c mut RayCounters,
}

enum WalkEnd {
    /// Left the mesh (or gave up) at this `t`.
    At(f64),
    /// The ray is opaque.
    Opaque,
}

impl<'a> Tracer<'a> {
    /// Builds the two hierarchies. `s` is the normalised scalar per vertex.
    pub(crate) fn new(
        mesh: &'a TetMesh,
        adj: &'a Adjacency,
        s: &'a [f64],
        quad_tol: f64,
        tf: &'a crate::scene::TransferFunction,
    ) -> Tracer<'a> {
        let (lo, hi) = mesh.bounds();
        let l_ref = if mesh.points.is_empty() {
            1.0
        } else {
            dot(sub(hi, lo), sub(hi, lo)).sqrt().max(f64::MIN_POSITIVE)
        };
        let big = lo.iter().chain(&hi).fold(0.0f64, |m, v| m.max(v.abs()));
        let pad = 1e-9 * l_ref + 1e-14 * big;
        let pts = &mesh.points[..];
        let tets = &mesh.tets[..];
        let tet_box = |vs: &[u32]| -> Aabb {
            let mut b = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for &v in vs {
                let p = pts[v as usize];
                for (k, &x) in p.iter().enumerate() {
                    b.0[k] = b.0[k].min(x);
                    b.1[k] = b.1[k].max(x);
                }
            }
            b
        };
        let mut bfaces = Vec::new();
        for (t, n) in adj.neighbors.iter().enumerate() {
            for (f, &nf) in n.iter().enumerate() {
                if nf == NO_NEIGHBOR {
                    bfaces.push((t as u32) << 2 | f as u32);
                }
            }
        }
        let face_boxes: Vec<Aabb> = bfaces
            .iter()
            .map(|&bf| {
                let tv = tets[(bf >> 2) as usize];
                let fv = FACE_VERTICES[(bf & 3) as usize];
                tet_box(&[tv[fv[0]], tv[fv[1]], tv[fv[2]]])
            })
            .collect();
        let tet_boxes: Vec<Aabb> = tets.iter().map(|t| tet_box(t)).collect();
        Tracer {
            pts,
            tets,
            nb: &adj.neighbors,
            s,
            quad: Integrator::new(tf, quad_tol, l_ref),
            face_bvh: Bvh::build(&face_boxes, pad),
            tet_bvh: Bvh::build(&tet_boxes, pad),
            bfaces,
            lo,
            hi,
            l_ref,
        }
    }

    /// Number of boundary faces.
    pub(crate) fn boundary_faces(&self) -> usize {
        self.bfaces.len()
    }

    fn scalar(&self, v: u32) -> f64 {
        self.s.get(v as usize).copied().unwrap_or(0.0)
    }

    /// Traces the ray `o + t d`, `t >= 0` (`d` unit): premultiplied colour
    /// and transmittance.
    pub(crate) fn trace(&self, o: [f64; 3], d: [f64; 3], ctr: &mut RayCounters) -> Accum {
        if self.tets.is_empty() {
            return Accum::CLEAR;
        }
        let centre = [
            0.5 * (self.lo[0] + self.hi[0]),
            0.5 * (self.lo[1] + self.hi[1]),
            0.5 * (self.lo[2] + self.hi[2]),
        ];
        let dist = dot(sub(centre, o), sub(centre, o)).sqrt();
        let eps_t = 1e-11 * (self.l_ref + dist);
        let mut ctx = RayCtx {
            o,
            d,
            eps_t,
            acc: Accum::CLEAR,
            ctr,
        };

        // Boundary entries, sorted by t (then by face id: deterministic).
        let mut hits: Vec<(f64, u32, f64, bool)> = Vec::new();
        self.face_bvh
            .for_each_on_ray(o, d, -eps_t, f64::INFINITY, |k| {
                let bf = self.bfaces[k as usize];
                let (tet, f) = (bf >> 2, (bf & 3) as usize);
                if let Some(p) = self.pierce(&ctx, tet, f) {
                    if p.t >= -eps_t && self.entering(&ctx, tet, f) {
                        hits.push((p.t, bf, p.s, p.on_ray));
                    }
                }
            });
        hits.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        ctx.ctr.boundary_hits += hits.len() as u64;

        let mut t_done = 0.0f64;
        let mut hit_any = false;
        // Origin inside the mesh?
        let inside_box = (0..3).all(|k| o[k] >= self.lo[k] - eps_t && o[k] <= self.hi[k] + eps_t);
        if inside_box && self.locate(&ctx, 0.0).is_some() {
            ctx.ctr.origin_inside += 1;
            ctx.ctr.mesh_entries += 1;
            hit_any = true;
            match self.walk(&mut ctx, None, 0.0, 0.0, true) {
                WalkEnd::At(t) => t_done = t,
                WalkEnd::Opaque => t_done = f64::INFINITY,
            }
        }
        for &(t, bf, s, on_ray) in &hits {
            if ctx.acc.t < T_MIN {
                break;
            }
            if t < t_done - eps_t {
                continue;
            }
            hit_any = true;
            ctx.ctr.mesh_entries += 1;
            match self.walk(
                &mut ctx,
                Some((bf >> 2, Some((bf & 3) as usize))),
                t.max(t_done).max(0.0),
                s,
                !on_ray || t < t_done || t < 0.0,
            ) {
                WalkEnd::At(te) => t_done = t_done.max(te),
                WalkEnd::Opaque => break,
            }
        }
        if hit_any {
            ctx.ctr.rays_hit += 1;
        }

        ctx.acc
    }

    /// Walks from `start` (a tet and the face it is entered through, or
    /// `None`: locate the tet at `t`) at `t`, where the scalar is `s` (to be
    /// recomputed in the tet if `s_suspect`), until the ray leaves the mesh.
    fn walk(
        &self,
        ctx: &mut RayCtx,
        start: Option<(u32, Option<usize>)>,
        mut t: f64,
        mut s: f64,
        mut s_suspect: bool,
    ) -> WalkEnd {
        let mut state = start;
        let mut zero_steps = 0u32;
        let mut recoveries = 0u32;
        // Why `state` is `None`: true after a stall or a boundary exit (a
        // successful location then counts as a recovery).
        let mut relocating = false;
        // Far more than any honest walk needs; a safety net only.
        let mut budget = 4 * self.tets.len() as u64 + 1024;
        loop {
            if ctx.acc.t < T_MIN {
                return WalkEnd::Opaque;
            }
            if budget == 0 || recoveries > MAX_RECOVERIES {
                ctx.ctr.walks_abandoned += 1;
                return WalkEnd::At(t);
            }
            budget -= 1;
            ctx.ctr.tets_visited += 1;
            let Some((tet, entry)) = state else {
                // Locate-and-clip step: the tet holding the ray beyond t, its
                // chord from barycentric clipping, the scalar from its own
                // linear function. Progress is guaranteed (the chord ends
                // beyond t + eps_t), so repeated recoveries cannot loop.
                let Some((tet, hi, f_hi)) = self.locate(ctx, t) else {
                    return WalkEnd::At(t);
                };
                if relocating {
                    ctx.ctr.walk_recoveries += 1;
                    recoveries += 1;
                }
                let s0 = self.s_on_ray(ctx, tet, t).unwrap_or(s);
                let s1 = self.s_on_ray(ctx, tet, hi).unwrap_or(s0);
                self.quad
                    .stretch(&mut ctx.acc, t, hi, s0, s1, &mut ctx.ctr.quad);
                t = hi;
                s = s1;
                s_suspect = true;
                zero_steps = 0;
                let n = self.nb[tet as usize][f_hi];
                relocating = true;
                state = if n == NO_NEIGHBOR || n as usize >= self.tets.len() {
                    None
                } else {
                    Some((n, self.nb[n as usize].iter().position(|&x| x == tet)))
                };
                continue;
            };
            // Exit: the pierced face (other than the entry) farthest along.
            let mut best: Option<(usize, Pierce)> = None;
            for f in 0..4 {
                if Some(f) == entry {
                    continue;
                }
                if let Some(p) = self.pierce(ctx, tet, f) {
                    if best.is_none_or(|(_, b)| p.t > b.t) {
                        best = Some((f, p));
                    }
                }
            }
            match best {
                // No way out, or the whole stretch of this tet lies behind
                // us (a zero-length step at a degenerate spot led backwards).
                None => state = None,
                Some((_, p)) if p.t < t - ctx.eps_t => state = None,
                Some((f, p)) => {
                    let t_exit = p.t.max(t);
                    if s_suspect {
                        // Entered through an ill-conditioned pierce: take the
                        // start value from this tet, on the ray.
                        s = self.s_on_ray(ctx, tet, t).unwrap_or(s);
                    }
                    let s_exit = if p.on_ray {
                        p.s
                    } else {
                        self.s_on_ray(ctx, tet, t_exit).unwrap_or(p.s)
                    };
                    s_suspect = !p.on_ray;
                    if t_exit > t {
                        self.quad
                            .stretch(&mut ctx.acc, t, t_exit, s, s_exit, &mut ctx.ctr.quad);
                        zero_steps = 0;
                    } else {
                        zero_steps += 1;
                        ctx.ctr.zero_length_steps += 1;
                    }
                    t = t_exit;
                    s = s_exit;
                    let n = self.nb[tet as usize][f];
                    state = if n == NO_NEIGHBOR || n as usize >= self.tets.len() {
                        // Leaving the mesh. The next (locate) step makes sure
                        // the ray really is outside beyond t: a walk confused
                        // at an edge or a vertex may leave too early.
                        None
                    } else if zero_steps > MAX_ZERO_STEPS {
                        None
                    } else {
                        Some((n, self.nb[n as usize].iter().position(|&x| x == tet)))
                    };
                }
            }
            relocating = state.is_none();
        }
    }

    /// The tet that contains the ray just beyond `t` (the one whose chord
    /// reaches farthest), the end of its chord and the face it leaves by.
    ///
    /// Unlike the walk this uses plain barycentric clipping (each barycentric
    /// coordinate is affine in `t`; the chord is where all four are >= 0, with
    /// a round-off margin): it does not depend on the signs of side products
    /// that are pure round-off when the ray runs through a vertex or along an
    /// edge. Flat tets are skipped (they hold no stretch).
    fn locate(&self, ctx: &RayCtx, t: f64) -> Option<(u32, f64, usize)> {
        let p = [
            ctx.o[0] + t * ctx.d[0],
            ctx.o[1] + t * ctx.d[1],
            ctx.o[2] + t * ctx.d[2],
        ];
        let mut best: Option<(u32, f64, usize)> = None;
        self.tet_bvh.for_each_containing(p, |tet| {
            let Some((lo, hi, f)) = self.chord(ctx, tet) else {
                return;
            };
            if lo <= t + ctx.eps_t && hi > t + ctx.eps_t && best.is_none_or(|(_, bt, _)| hi > bt) {
                best = Some((tet, hi, f));
            }
        });
        best
    }

    /// The barycentric coordinates of the ray point `o + t d` in `tet` as
    /// affine functions of `t`: `lambda_k(t) = a_k + b_k t` (Cramer's rule,
    /// ray-relative), or `None` for a (nearly) flat tet (`|6 V| <= 1e-12 L^3`,
    /// `L` its longest edge from vertex 0).
    fn bary_on_ray(&self, ctx: &RayCtx, tet: u32) -> Option<([f64; 4], [f64; 4])> {
        let tv = self.tets[tet as usize];
        let p = tv.map(|v| sub(self.pts[v as usize], ctx.o));
        let (e1, e2, e3) = (sub(p[1], p[0]), sub(p[2], p[0]), sub(p[3], p[0]));
        let c23 = cross(e2, e3);
        let det = dot(e1, c23);
        let l2 = dot(e1, e1).max(dot(e2, e2)).max(dot(e3, e3));
        let flat = det.abs() <= 1e-12 * l2 * l2.sqrt();
        if flat || det.is_nan() {
            return None;
        }
        let x0 = sub([0.0; 3], p[0]);
        let d = ctx.d;
        let a = [
            dot(x0, c23) / det,
            dot(e1, cross(x0, e3)) / det,
            dot(e1, cross(e2, x0)) / det,
        ];
        let b = [
            dot(d, c23) / det,
            dot(e1, cross(d, e3)) / det,
            dot(e1, cross(e2, d)) / det,
        ];
        Some((
            [1.0 - a[0] - a[1] - a[2], a[0], a[1], a[2]],
            [-b[0] - b[1] - b[2], b[0], b[1], b[2]],
        ))
    }

    /// The parameter interval where the ray is inside `tet` (barycentric
    /// coordinates >= -1e-12) and the face whose coordinate ends it, or `None`
    /// if the ray misses the tet or the tet is flat.
    fn chord(&self, ctx: &RayCtx, tet: u32) -> Option<(f64, f64, usize)> {
        let (a, b) = self.bary_on_ray(ctx, tet)?;
        let (mut lo, mut hi, mut f_hi) = (f64::NEG_INFINITY, f64::INFINITY, 0);
        let margin = 1e-12;
        // Coordinate k belongs to vertex k; it vanishes on face k.
        for k in 0..4 {
            if b[k] > 0.0 {
                lo = lo.max((-margin - a[k]) / b[k]);
            } else if b[k] < 0.0 {
                let tk = (-margin - a[k]) / b[k];
                if tk < hi {
                    hi = tk;
                    f_hi = k;
                }
            } else if a[k] < -margin {
                return None;
            }
        }
        (lo <= hi && hi.is_finite()).then_some((lo, hi, f_hi))
    }

    /// The tet's linear scalar at the ray point `o + t d`, or `None` for a
    /// (nearly) flat tet.
    fn s_on_ray(&self, ctx: &RayCtx, tet: u32, t: f64) -> Option<f64> {
        let (a, b) = self.bary_on_ray(ctx, tet)?;
        let tv = self.tets[tet as usize];
        Some((0..4).map(|k| (a[k] + b[k] * t) * self.scalar(tv[k])).sum())
    }

    /// Whether the ray's line pierces face `f` of `tet`, and where.
    fn pierce(&self, ctx: &RayCtx, tet: u32, f: usize) -> Option<Pierce> {
        let tv = self.tets[tet as usize];
        let fv = FACE_VERTICES[f];
        let mut v = [tv[fv[0]], tv[fv[1]], tv[fv[2]]];
        v.sort_unstable();
        let p = v.map(|i| sub(self.pts[i as usize], ctx.o));
        let d = ctx.d;
        let e = |a: [f64; 3], b: [f64; 3]| dot(d, cross(a, sub(b, a)));
        let e01 = e(p[0], p[1]);
        let e12 = e(p[1], p[2]);
        let e20 = -e(p[0], p[2]);
        let pos = e01 >= 0.0 && e12 >= 0.0 && e20 >= 0.0;
        let neg = e01 <= 0.0 && e12 <= 0.0 && e20 <= 0.0;
        if !(pos || neg) {
            return None;
        }
        let w = [e12, e20, e01];
        let sum = w[0] + w[1] + w[2];
        if sum == 0.0 || !sum.is_finite() {
            return None;
        }
        let x = [
            (w[0] * p[0][0] + w[1] * p[1][0] + w[2] * p[2][0]) / sum,
            (w[0] * p[0][1] + w[1] * p[1][1] + w[2] * p[2][1]) / sum,
            (w[0] * p[0][2] + w[1] * p[1][2] + w[2] * p[2][2]) / sum,
        ];
        let s =
            (w[0] * self.scalar(v[0]) + w[1] * self.scalar(v[1]) + w[2] * self.scalar(v[2])) / sum;
        let t = dot(d, x);
        let r = [x[0] - t * d[0], x[1] - t * d[1], x[2] - t * d[2]];
        let on_ray = dot(r, r).sqrt() <= 1e-10 * (self.l_ref + t.abs());
        Some(Pierce { t, s, on_ray })
    }

    /// Whether the ray goes into `tet` across its face `f` (the tet lies on
    /// the far side of the face).
    fn entering(&self, ctx: &RayCtx, tet: u32, f: usize) -> bool {
        let tv = self.tets[tet as usize];
        let fv = FACE_VERTICES[f];
        let q = |k: usize| sub(self.pts[tv[k] as usize], ctx.o);
        let (a, b, c, apex) = (q(fv[0]), q(fv[1]), q(fv[2]), q(f));
        let n = cross(sub(b, a), sub(c, a));
        dot(n, ctx.d) * dot(n, sub(apex, a)) > 0.0
    }
}
