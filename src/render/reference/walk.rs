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
//! # Entries (non-convex meshes) and recovery
//!
//! All boundary faces (no neighbour) pierced by the ray at `t >= 0` are found
//! with a BVH, kept when the ray goes *into* their tet there, and sorted by
//! `t`. They are taken in order; one whose `t` lies before the end of the
//! previous walk (minus a tiny `eps_t`) was already passed inside the mesh and
//! is skipped. So every re-entry of a non-convex mesh starts a new walk.
//! If the ray origin is inside the mesh (a perspective eye inside, an
//! orthographic eye plane cutting the mesh) the tet containing it is located
//! with a BVH over the tets and the first walk starts there.
//!
//! A walk that stalls (no pierced face, more than `MAX_ZERO_STEPS` steps in a
//! row without progress — a ray through a vertex can cycle around it —, or a
//! degenerate neighbour) *recovers*: the tet that contains the ray just beyond
//! `t_cur` is located with the tet BVH (the one whose stretch reaches
//! farthest) and the walk resumes there from `t_cur`, so no stretch is
//! skipped. If none contains it, the ray is outside the mesh and the next
//! boundary entry takes over. Recoveries are counted; a walk with too many is
//! abandoned (counted separately) and the boundary entries take over.

use super::bvh::{Aabb, Bvh};
use super::quadrature::{Accum, Integrator, QuadCounters};
use super::T_MIN;
use crate::data::mesh::{FACE_VERTICES, NO_NEIGHBOR};
use crate::data::{Adjacency, TetMesh};

/// Steps in a row that make no progress along the ray before recovering.
const MAX_ZERO_STEPS: u32 = 48;
/// Recoveries of one ray before its walk is abandoned.
const MAX_RECOVERIES: u32 = 64;

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
    recoveries: u32,
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
                for k in 0..3 {
                    b.0[k] = b.0[k].min(p[k]);
                    b.1[k] = b.1[k].max(p[k]);
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
            recoveries: 0,
        };

        // Boundary entries, sorted by t (then by face id: deterministic).
        let mut hits: Vec<(f64, u32, f64)> = Vec::new();
        self.face_bvh
            .for_each_on_ray(o, d, -eps_t, f64::INFINITY, |k| {
                let bf = self.bfaces[k as usize];
                let (tet, f) = (bf >> 2, (bf & 3) as usize);
                if let Some(p) = self.pierce(&ctx, tet, f) {
                    if p.t >= -eps_t && self.entering(&ctx, tet, f) {
                        hits.push((p.t, bf, p.s));
                    }
                }
            });
        hits.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        ctx.ctr.boundary_hits += hits.len() as u64;

        let mut t_done = 0.0f64;
        let mut hit_any = false;
        // Origin inside the mesh?
        let inside_box = (0..3).all(|k| o[k] >= self.lo[k] - eps_t && o[k] <= self.hi[k] + eps_t);
        if inside_box {
            if let Some((tet, s0)) = self.locate(&ctx, 0.0) {
                ctx.ctr.origin_inside += 1;
                ctx.ctr.mesh_entries += 1;
                hit_any = true;
                match self.walk(&mut ctx, tet, None, 0.0, s0) {
                    WalkEnd::At(t) => t_done = t,
                    WalkEnd::Opaque => t_done = f64::INFINITY,
                }
            }
        }
        for &(t, bf, s) in &hits {
            if ctx.acc.t < T_MIN {
                break;
            }
            if t < t_done - eps_t {
                continue;
            }
            hit_any = true;
            ctx.ctr.mesh_entries += 1;
            ctx.recoveries = 0;
            match self.walk(
                &mut ctx,
                bf >> 2,
                Some((bf & 3) as usize),
                t.max(t_done).max(0.0),
                s,
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

    /// Walks from `tet` (entered through `entry`, or from inside) at `t`,
    /// where the scalar is `s`, until the ray leaves the mesh.
    fn walk(
        &self,
        ctx: &mut RayCtx,
        mut tet: u32,
        mut entry: Option<usize>,
        mut t: f64,
        mut s: f64,
    ) -> WalkEnd {
        let mut zero_steps = 0u32;
        // Far more than any honest walk needs; a safety net only.
        let mut budget = 4 * self.tets.len() as u64 + 1024;
        loop {
            if ctx.acc.t < T_MIN {
                return WalkEnd::Opaque;
            }
            budget = budget.saturating_sub(1);
            ctx.ctr.tets_visited += 1;
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
            let stalled = match best {
                // No way out, or the whole stretch of this tet lies behind
                // us (a zero-length step at a degenerate spot led backwards).
                None => true,
                Some((_, p)) if p.t < t - ctx.eps_t => true,
                Some((f, p)) => {
                    let t_exit = p.t.max(t);
                    if t_exit > t {
                        self.quad
                            .stretch(&mut ctx.acc, t, t_exit, s, p.s, &mut ctx.ctr.quad);
                        zero_steps = 0;
                    } else {
                        zero_steps += 1;
                        ctx.ctr.zero_length_steps += 1;
                    }
                    t = t_exit;
                    s = p.s;
                    let n = self.nb.get(tet as usize).map_or(NO_NEIGHBOR, |n| n[f]);
                    if n == NO_NEIGHBOR || n as usize >= self.tets.len() {
                        // Leaving the mesh. Make sure the ray really is
                        // outside beyond t: a walk confused at an edge or a
                        // vertex on the boundary may leave too early.
                        match self.locate(ctx, t) {
                            None => return WalkEnd::At(t),
                            Some((t2, s2)) => {
                                ctx.ctr.walk_recoveries += 1;
                                ctx.recoveries += 1;
                                if ctx.recoveries > MAX_RECOVERIES {
                                    ctx.ctr.walks_abandoned += 1;
                                    return WalkEnd::At(t);
                                }
                                tet = t2;
                                entry = None;
                                s = s2;
                                zero_steps = 0;
                                continue;
                            }
                        }
                    }
                    entry = self.nb[n as usize].iter().position(|&x| x == tet);
                    tet = n;
                    zero_steps > MAX_ZERO_STEPS || budget == 0
                }
            };
            if stalled {
                ctx.ctr.walk_recoveries += 1;
                ctx.recoveries += 1;
                if ctx.recoveries > MAX_RECOVERIES || budget == 0 {
                    ctx.ctr.walks_abandoned += 1;
                    return WalkEnd::At(t);
                }
                match self.locate(ctx, t) {
                    Some((t2, s2)) => {
                        tet = t2;
                        entry = None;
                        s = s2;
                        zero_steps = 0;
                    }
                    None => return WalkEnd::At(t),
                }
            }
        }
    }

    /// The tet that contains the ray just beyond `t` (the one whose stretch
    /// reaches farthest), and the scalar at `t` in it.
    fn locate(&self, ctx: &RayCtx, t: f64) -> Option<(u32, f64)> {
        let p = [
            ctx.o[0] + t * ctx.d[0],
            ctx.o[1] + t * ctx.d[1],
            ctx.o[2] + t * ctx.d[2],
        ];
        let mut best: Option<(u32, f64, f64)> = None; // (tet, t_out, s at t)
        self.tet_bvh.for_each_containing(p, |tet| {
            let (mut a, mut b): (Option<Pierce>, Option<Pierce>) = (None, None);
            for f in 0..4 {
                if let Some(q) = self.pierce(ctx, tet, f) {
                    if a.is_none_or(|a| q.t < a.t) {
                        a = Some(q);
                    }
                    if b.is_none_or(|b| q.t > b.t) {
                        b = Some(q);
                    }
                }
            }
            let (Some(a), Some(b)) = (a, b) else { return };
            if a.t <= t + ctx.eps_t && b.t > t + ctx.eps_t && best.is_none_or(|(_, bt, _)| b.t > bt)
            {
                // The scalar is linear along the chord.
                let s = if b.t > a.t {
                    a.s + (b.s - a.s) * ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0)
                } else {
                    a.s
                };
                best = Some((tet, b.t, s));
            }
        });
        best.map(|(tet, _, s)| (tet, s))
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
        Some(Pierce { t: dot(d, x), s })
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
