//! The built-in demo dataset: a synthetic arterial bifurcation, meshed with
//! tetrahedra and carrying a flow-like field, generated deterministically so
//! the quick start needs no download.
//!
//! # Geometry (millimetres)
//!
//! Four tubes, each a cubic Bézier centreline with a linearly tapering radius:
//!
//! - **parent**: from the inlet near `(8, 0, -100)` to the junction at the
//!   origin, an S-curve in x with a little y; radius 10 → 9; flat inlet cap;
//! - **daughter A**: from the junction to `(42, 10, 72)`, radius 7 → 6, flat
//!   outlet cap;
//! - **daughter B**: from the junction to `(-34, -14, 75)`, radius 6 → 5, flat
//!   outlet cap;
//! - **side branch**: leaves the parent at 45 % of its length towards +x,
//!   radius 4 → 3.5, flat outlet cap.
//!
//! The solid is implicit: each tube's signed distance is `|p - c(s)| - r(s)`
//! to its centreline polyline (48 points per tube), cut by the planes of its
//! open ends; the tubes are merged with a polynomial smooth minimum (radius
//! 4 mm at the junction, 3 mm at the carina, 2 mm at the side branch), which
//! gives filleted junctions. The bifurcation lies roughly in the x-z plane and
//! the flow runs towards +z.
//!
//! # Mesh
//!
//! 1. A regular lattice of spacing `h` covers the solid; `h` is chosen from
//!    `cells_target` and the solid's volume (estimated on a 3 mm grid) so that
//!    about `6 V / h³` tetrahedra result.
//! 2. Each lattice cube is split into the 6 tetrahedra of the Freudenthal
//!    (Kuhn) subdivision around its main diagonal, the same way in every cube,
//!    so the lattice tetrahedralisation is conforming (dihedral angles 45°,
//!    60°, 90°).
//! 3. A tetrahedron is kept when the mean signed distance of its 4 vertices is
//!    negative. Any subset of a conforming mesh is conforming. Where the kept
//!    set pinches (a boundary edge with 4 boundary triangles, or a boundary
//!    vertex whose boundary triangles form two fans), the lattice tetrahedra
//!    around it are all added or all removed, by majority, until none is left;
//!    then only the largest face-connected component is kept.
//! 4. The staircase boundary is moved onto the surface: each boundary vertex is
//!    moved towards its projection on the zero level set (two Newton steps),
//!    taking the full step or the largest of 1/2, 1/4, 1/8 of it that keeps the
//!    smallest dihedral angle of every incident tetrahedron at or above a
//!    floor (`quality_floor_deg`, default 15°) or not worse than before. Then
//!    interior vertices whose worst incident tetrahedron is below 35° are
//!    moved to the mean of their incident tetrahedra's centroids when that
//!    improves their worst tetrahedron. Several passes alternate the two. A
//!    move never inverts a tetrahedron: the check rejects any step that
//!    makes a volume non-positive.
//! 5. Vertices are relaxed in 8 colour classes (lattice index parity): two
//!    vertices of one class never share a tetrahedron, so each class is moved
//!    in parallel with a result independent of the thread count. Nothing uses
//!    hashing or randomness, so the same parameters give a bit-identical mesh.
//!
//! At the default 150 000 target the mesh has about 151 000 tetrahedra and
//! 30 000 vertices; the smallest dihedral angle is at least the floor (15°)
//! and boundary vertices end on the surface to a small fraction of `h` except
//! where the floor stopped them (see the tests, which print statistics).
//!
//! # Fields (at the vertices)
//!
//! - `velocity` [m/s]: the cross-section mean velocity `Q(s) / (π r(s)²)`
//!   along the local centreline tangent, blended between tubes near the
//!   junctions with weights that fall to 0 over 4 mm of signed-distance
//!   difference. Inlet mean 0.4 m/s; the side branch takes 10 % of the
//!   flow, daughter A 50 %, daughter B 40 %.
//! - `speed` [m/s]: `2 |velocity| (1 - (ρ/R)²)`, the Poiseuille profile, with
//!   `d` the distance to the wall (minus the signed distance), `ρ` the
//!   distance to the (blended) centreline and `R = d + ρ`. It is exactly 0 on
//!   the boundary vertices and positive inside.
//! - `pressure` [Pa]: Poiseuille pressure drop `dp/ds = -8 μ Q / (π r⁴)` with
//!   blood viscosity `μ = 3.5 mPa s`, integrated along each tube from the
//!   inlet, continuous at the junctions, shifted so that the lowest outlet is
//!   at 0. It falls along the flow.

use rayon::prelude::*;

use crate::data::mesh::{Adjacency, Field, TetMesh, FACE_VERTICES, NO_NEIGHBOR};
use crate::scene::{Scene, TransferFunction};

/// Parameters of the demo dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoParams {
    /// Approximate number of tetrahedra (the lattice spacing is chosen for it).
    pub cells_target: usize,
    /// Boundary vertices are not moved onto the surface further than keeps
    /// every incident tetrahedron's smallest dihedral angle above this.
    pub quality_floor_deg: f64,
    /// Passes of boundary snapping plus interior smoothing.
    pub relax_passes: usize,
}

impl Default for DemoParams {
    fn default() -> Self {
        DemoParams { cells_target: 150_000, quality_floor_deg: 15.0, relax_passes: 4 }
    }
}

// ---------------------------------------------------------------- vectors

type V3 = [f64; 3];

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn scale(a: V3, k: f64) -> V3 {
    [a[0] * k, a[1] * k, a[2] * k]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V3, b: V3) -> V3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
fn normalize(a: V3) -> V3 {
    scale(a, 1.0 / norm(a))
}
fn lerp3(a: V3, b: V3, t: f64) -> V3 {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}
fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}
/// Polynomial smooth minimum (exact `min` when `|a - b| >= k`).
fn smin(a: f64, b: f64, k: f64) -> f64 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

// ---------------------------------------------------------------- geometry

/// "Far" signed distance for tubes culled as irrelevant.
const BIG: f64 = 1e9;
/// Blood viscosity, Pa s.
const MU: f64 = 3.5e-3;
/// Mean inlet velocity, m/s.
const U_INLET: f64 = 0.4;
/// Points per centreline polyline.
const CENTRELINE_POINTS: usize = 48;
/// Segments per culling chunk.
const CHUNK: usize = 6;
/// Field-blending width (mm of signed-distance difference).
const BLEND: f64 = 4.0;
const K_JUNCTION: f64 = 4.0;
const K_CARINA: f64 = 3.0;
const K_SIDE: f64 = 2.0;

const PARENT: usize = 0;
const SIDE: usize = 1;
const DAUGHTER_A: usize = 2;
const DAUGHTER_B: usize = 3;

fn bezier(c: &[V3; 4], t: f64) -> V3 {
    let s = 1.0 - t;
    let w = [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t];
    let mut p = [0.0; 3];
    for (ci, wi) in c.iter().zip(w) {
        p = add(p, scale(*ci, wi));
    }
    p
}
fn bezier_tangent(c: &[V3; 4], t: f64) -> V3 {
    let s = 1.0 - t;
    let d = add(
        add(scale(sub(c[1], c[0]), 3.0 * s * s), scale(sub(c[2], c[1]), 6.0 * s * t)),
        scale(sub(c[3], c[2]), 3.0 * t * t),
    );
    normalize(d)
}

#[derive(Debug, Clone)]
struct Chunk {
    first_seg: usize,
    end_seg: usize,
    lo: V3,
    hi: V3,
}

/// One vessel: a centreline polyline with radius, flow rate and pressure per point.
#[derive(Debug, Clone)]
struct Tube {
    pts: Vec<V3>,
    tan: Vec<V3>,
    rad: Vec<f64>,
    arc: Vec<f64>,
    flow: Vec<f64>,
    pres: Vec<f64>,
    chunks: Vec<Chunk>,
    open_start: bool,
    open_end: bool,
}

/// What one tube says about a point.
#[derive(Debug, Clone, Copy)]
struct Hit {
    /// Signed distance to this tube's surface (`BIG` when culled).
    sdf: f64,
    /// Distance to the centreline.
    dist: f64,
    tangent: V3,
    radius: f64,
    flow: f64,
    pressure: f64,
}

const MISS: Hit = Hit { sdf: BIG, dist: BIG, tangent: [0.0; 3], radius: 1.0, flow: 0.0, pressure: 0.0 };

impl Tube {
    fn new(ctrl: [V3; 4], r0: f64, r1: f64, open_start: bool, open_end: bool, cull: f64) -> Tube {
        let n = CENTRELINE_POINTS;
        let ts: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let pts: Vec<V3> = ts.iter().map(|&t| bezier(&ctrl, t)).collect();
        let tan: Vec<V3> = ts.iter().map(|&t| bezier_tangent(&ctrl, t)).collect();
        let rad: Vec<f64> = ts.iter().map(|&t| lerp(r0, r1, t)).collect();
        let mut arc = vec![0.0; n];
        for i in 1..n {
            arc[i] = arc[i - 1] + norm(sub(pts[i], pts[i - 1]));
        }
        let mut chunks = Vec::new();
        let mut first = 0;
        while first < n - 1 {
            let end = (first + CHUNK).min(n - 1);
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            let mut rmax: f64 = 0.0;
            for i in first..=end {
                for k in 0..3 {
                    lo[k] = lo[k].min(pts[i][k]);
                    hi[k] = hi[k].max(pts[i][k]);
                }
                rmax = rmax.max(rad[i]);
            }
            let m = rmax + cull;
            chunks.push(Chunk { first_seg: first, end_seg: end, lo: sub(lo, [m; 3]), hi: add(hi, [m; 3]) });
            first = end;
        }
        Tube { pts, tan, rad, arc, flow: vec![0.0; n], pres: vec![0.0; n], chunks, open_start, open_end }
    }

    fn len(&self) -> f64 {
        self.arc[self.arc.len() - 1]
    }

    /// Closest centreline point among the chunks whose box holds `p`.
    fn hit(&self, p: V3) -> Hit {
        let mut best = (f64::INFINITY, 0usize, 0.0f64);
        for c in &self.chunks {
            if (0..3).any(|k| p[k] < c.lo[k] || p[k] > c.hi[k]) {
                continue;
            }
            for s in c.first_seg..c.end_seg {
                let a = self.pts[s];
                let ab = sub(self.pts[s + 1], a);
                let u = (dot(sub(p, a), ab) / dot(ab, ab)).clamp(0.0, 1.0);
                let d2 = {
                    let q = sub(p, add(a, scale(ab, u)));
                    dot(q, q)
                };
                if d2 < best.0 {
                    best = (d2, s, u);
                }
            }
        }
        if best.0 == f64::INFINITY {
            return MISS;
        }
        let (d2, s, u) = best;
        let dist = d2.sqrt();
        let radius = lerp(self.rad[s], self.rad[s + 1], u);
        let mut sdf = dist - radius;
        let n = self.pts.len();
        if self.open_start {
            sdf = sdf.max(dot(sub(self.pts[0], p), self.tan[0]));
        }
        if self.open_end {
            sdf = sdf.max(dot(sub(p, self.pts[n - 1]), self.tan[n - 1]));
        }
        Hit {
            sdf,
            dist,
            tangent: normalize(lerp3(self.tan[s], self.tan[s + 1], u)),
            radius,
            flow: lerp(self.flow[s], self.flow[s + 1], u),
            pressure: lerp(self.pres[s], self.pres[s + 1], u),
        }
    }

    /// Integrates the Poiseuille pressure drop from `p0` at the start.
    fn integrate_pressure(&mut self, p0: f64) {
        let g = |i: usize| 8.0 * MU * self.flow[i] / (std::f64::consts::PI * (self.rad[i] * 1e-3).powi(4));
        let mut p = vec![p0; self.pts.len()];
        for i in 1..p.len() {
            let ds = (self.arc[i] - self.arc[i - 1]) * 1e-3;
            p[i] = p[i - 1] - 0.5 * (g(i - 1) + g(i)) * ds;
        }
        self.pres = p;
    }

    /// Pressure at arc length `s` (linear in between points).
    fn pressure_at_arc(&self, s: f64) -> f64 {
        let i = self.arc.partition_point(|&a| a <= s).clamp(1, self.arc.len() - 1);
        let u = ((s - self.arc[i - 1]) / (self.arc[i] - self.arc[i - 1])).clamp(0.0, 1.0);
        lerp(self.pres[i - 1], self.pres[i], u)
    }
}

/// The implicit solid and its flow.
#[derive(Debug, Clone)]
struct Geometry {
    tubes: [Tube; 4],
}

/// Parent-curve parameter where the side branch leaves.
const SIDE_T: f64 = 0.45;

impl Geometry {
    /// `cull`: tubes farther than this (plus their radius) from a point are
    /// not evaluated there; the signed distance is then only known to be
    /// larger than `cull - K_JUNCTION / 4`-ish, which is all the mesher needs.
    fn new(cull: f64) -> Geometry {
        let parent_ctrl = [[8.0, 0.0, -100.0], [-12.0, -6.0, -70.0], [0.0, 4.0, -35.0], [0.0, 0.0, 0.0]];
        let o = bezier(&parent_ctrl, SIDE_T);
        let side_ctrl = [o, add(o, [10.0, -2.0, 3.0]), add(o, [22.0, -8.0, 12.0]), add(o, [30.0, -14.0, 26.0])];
        let mut parent = Tube::new(parent_ctrl, 10.0, 9.0, true, false, cull);
        let mut side = Tube::new(side_ctrl, 4.0, 3.5, false, true, cull);
        let mut da = Tube::new([[0.0; 3], [8.0, 0.0, 18.0], [30.0, 6.0, 35.0], [42.0, 10.0, 72.0]], 7.0, 6.0, false, true, cull);
        let mut db = Tube::new([[0.0; 3], [-8.0, 0.0, 18.0], [-28.0, -8.0, 38.0], [-34.0, -14.0, 75.0]], 6.0, 5.0, false, true, cull);

        // Flow rates (m³/s): the side branch takes 10 %, daughters 50 % and 40 %.
        let q_in = U_INLET * std::f64::consts::PI * (parent.rad[0] * 1e-3).powi(2);
        let (f_side, f_a, f_b) = (0.10, 0.50, 0.40);
        let side_arc = {
            let i = ((CENTRELINE_POINTS - 1) as f64 * SIDE_T).round() as usize;
            parent.arc[i]
        };
        let w = 2.0 * side.rad[0];
        parent.flow = parent.arc.iter().map(|&s| q_in * (1.0 - f_side * smoothstep((s - side_arc) / w + 0.5))).collect();
        side.flow = vec![f_side * q_in; CENTRELINE_POINTS];
        da.flow = vec![f_a * q_in; CENTRELINE_POINTS];
        db.flow = vec![f_b * q_in; CENTRELINE_POINTS];

        parent.integrate_pressure(0.0);
        side.integrate_pressure(parent.pressure_at_arc(side_arc));
        let pj = parent.pres[CENTRELINE_POINTS - 1];
        da.integrate_pressure(pj);
        db.integrate_pressure(pj);
        let mut tubes = [parent, side, da, db];
        let low = tubes.iter().map(|t| t.pres[CENTRELINE_POINTS - 1]).fold(f64::INFINITY, f64::min);
        for t in &mut tubes {
            for p in &mut t.pres {
                *p -= low;
            }
        }
        Geometry { tubes }
    }

    fn hits(&self, p: V3) -> [Hit; 4] {
        [self.tubes[0].hit(p), self.tubes[1].hit(p), self.tubes[2].hit(p), self.tubes[3].hit(p)]
    }

    fn phi_of(h: &[Hit; 4]) -> f64 {
        let trunk = smin(h[PARENT].sdf, h[SIDE].sdf, K_SIDE);
        let crown = smin(h[DAUGHTER_A].sdf, h[DAUGHTER_B].sdf, K_CARINA);
        smin(trunk, crown, K_JUNCTION)
    }

    /// Signed distance (negative inside).
    fn phi(&self, p: V3) -> f64 {
        Self::phi_of(&self.hits(p))
    }

    /// Closest point on the surface, by two Newton steps with a
    /// forward-difference gradient.
    fn project(&self, mut p: V3, h: f64) -> V3 {
        let e = 1e-4 * h;
        for _ in 0..2 {
            let f = self.phi(p);
            let g = [
                (self.phi([p[0] + e, p[1], p[2]]) - f) / e,
                (self.phi([p[0], p[1] + e, p[2]]) - f) / e,
                (self.phi([p[0], p[1], p[2] + e]) - f) / e,
            ];
            let g2 = dot(g, g);
            if g2 < 1e-12 {
                break;
            }
            p = sub(p, scale(g, f / g2));
        }
        p
    }

    /// `(velocity, speed, pressure)` at `p`; `d_min` is the smallest wall
    /// distance used for the no-slip profile (keeps interior vertices > 0).
    fn flow_at(&self, p: V3, d_min: f64) -> (V3, f64, f64) {
        let h = self.hits(p);
        let phi = Self::phi_of(&h);
        let smin_sdf = h.iter().map(|x| x.sdf).fold(f64::INFINITY, f64::min);
        let mut wsum = 0.0;
        let mut vel = [0.0; 3];
        let mut pres = 0.0;
        let mut rho = 0.0;
        for x in &h {
            if x.sdf >= BIG {
                continue;
            }
            let w = (1.0 - (x.sdf - smin_sdf) / BLEND).max(0.0).powi(2);
            if w == 0.0 {
                continue;
            }
            let u = x.flow / (std::f64::consts::PI * (x.radius * 1e-3).powi(2));
            vel = add(vel, scale(x.tangent, w * u));
            pres += w * x.pressure;
            rho += w * x.dist;
            wsum += w;
        }
        if wsum == 0.0 {
            return ([0.0; 3], 0.0, 0.0);
        }
        let vel = scale(vel, 1.0 / wsum);
        let rho = rho / wsum;
        let d = (-phi).max(d_min);
        let profile = 1.0 - (rho / (d + rho)).powi(2);
        (vel, 2.0 * norm(vel) * profile, pres / wsum)
    }

    /// Axis-aligned bounds of the tubes (centreline ± radius).
    fn bounds(&self) -> (V3, V3) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for t in &self.tubes {
            for (p, r) in t.pts.iter().zip(&t.rad) {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k] - r);
                    hi[k] = hi[k].max(p[k] + r);
                }
            }
        }
        (lo, hi)
    }

    /// Solid volume estimated by counting 3 mm grid cells (centre inside).
    fn volume_estimate(&self) -> f64 {
        let step = 3.0;
        let (lo, hi) = self.bounds();
        let n = |k: usize| ((hi[k] - lo[k]) / step).ceil() as usize + 1;
        let (nx, ny, nz) = (n(0), n(1), n(2));
        let inside: usize = (0..nz)
            .into_par_iter()
            .map(|k| {
                let mut c = 0;
                for j in 0..ny {
                    for i in 0..nx {
                        let p = [lo[0] + (i as f64 + 0.5) * step, lo[1] + (j as f64 + 0.5) * step, lo[2] + (k as f64 + 0.5) * step];
                        if self.phi(p) < 0.0 {
                            c += 1;
                        }
                    }
                }
                c
            })
            .sum();
        inside as f64 * step * step * step
    }
}

// ---------------------------------------------------------------- lattice

/// The 6 Freudenthal tetrahedra of a unit cube, as corner offsets, positively
/// oriented: for axis order `(a, b, c)`: 0, e_a, e_a + e_b, 1 (odd orders
/// have their middle two corners swapped).
fn kuhn_templates() -> [[[usize; 3]; 4]; 6] {
    const PERMS: [[usize; 3]; 6] = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
    let mut out = [[[0usize; 3]; 4]; 6];
    for (m, p) in PERMS.iter().enumerate() {
        let mut c1 = [0usize; 3];
        c1[p[0]] = 1;
        let mut c2 = c1;
        c2[p[1]] = 1;
        let odd = matches!(m, 1 | 2 | 5);
        out[m] = if odd { [[0; 3], c2, c1, [1; 3]] } else { [[0; 3], c1, c2, [1; 3]] };
    }
    out
}

struct Lattice {
    origin: V3,
    h: f64,
    n: [usize; 3],
    templates: [[[usize; 3]; 4]; 6],
}

impl Lattice {
    fn vid(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.n[0] * (j + self.n[1] * k)
    }
    fn vijk(&self, v: usize) -> [usize; 3] {
        [v % self.n[0], (v / self.n[0]) % self.n[1], v / (self.n[0] * self.n[1])]
    }
    fn pos(&self, v: usize) -> V3 {
        let [i, j, k] = self.vijk(v);
        [self.origin[0] + i as f64 * self.h, self.origin[1] + j as f64 * self.h, self.origin[2] + k as f64 * self.h]
    }
    fn cubes(&self) -> [usize; 3] {
        [self.n[0] - 1, self.n[1] - 1, self.n[2] - 1]
    }
    /// Lattice vertex ids of lattice tetrahedron `t` (cube `t / 6`, template `t % 6`).
    fn tet(&self, t: usize) -> [u32; 4] {
        let c = self.cubes();
        let cube = t / 6;
        let (i, j, k) = (cube % c[0], (cube / c[0]) % c[1], cube / (c[0] * c[1]));
        self.templates[t % 6].map(|o| self.vid(i + o[0], j + o[1], k + o[2]) as u32)
    }
    /// Lattice tetrahedra that have lattice vertex `v` as a corner.
    fn tets_around(&self, v: usize) -> Vec<usize> {
        let [i, j, k] = self.vijk(v);
        let c = self.cubes();
        let mut out = Vec::new();
        for dk in 0..2 {
            for dj in 0..2 {
                for di in 0..2 {
                    if i < di || j < dj || k < dk || i - di >= c[0] || j - dj >= c[1] || k - dk >= c[2] {
                        continue;
                    }
                    let cube = (i - di) + c[0] * ((j - dj) + c[1] * (k - dk));
                    for (m, tpl) in self.templates.iter().enumerate() {
                        if tpl.contains(&[di, dj, dk]) {
                            out.push(cube * 6 + m);
                        }
                    }
                }
            }
        }
        out
    }
}

/// A mesh cut out of the lattice, with each mesh vertex's lattice id.
struct Extracted {
    mesh: TetMesh,
    lattice_vertex: Vec<usize>,
    lattice_tet: Vec<usize>,
}

fn extract(lat: &Lattice, keep: &[bool]) -> Extracted {
    let nv = lat.n[0] * lat.n[1] * lat.n[2];
    let lattice_tet: Vec<usize> = (0..keep.len()).filter(|&t| keep[t]).collect();
    let mut used = vec![false; nv];
    for &t in &lattice_tet {
        for v in lat.tet(t) {
            used[v as usize] = true;
        }
    }
    let mut map = vec![u32::MAX; nv];
    let mut lattice_vertex = Vec::new();
    for v in 0..nv {
        if used[v] {
            map[v] = lattice_vertex.len() as u32;
            lattice_vertex.push(v);
        }
    }
    let tets = lattice_tet.iter().map(|&t| lat.tet(t).map(|v| map[v as usize])).collect();
    let points = lattice_vertex.iter().map(|&v| lat.pos(v)).collect();
    Extracted { mesh: TetMesh { points, tets, fields: Vec::new() }, lattice_vertex, lattice_tet }
}

// ---------------------------------------------------------------- topology checks

/// Boundary triangles (vertex triples) of a mesh, from its adjacency.
fn boundary_triangles(mesh: &TetMesh, adj: &Adjacency) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    for (t, nb) in adj.neighbors.iter().enumerate() {
        for (f, &n) in nb.iter().enumerate() {
            if n == NO_NEIGHBOR {
                let s = FACE_VERTICES[f];
                let tet = mesh.tets[t];
                out.push([tet[s[0]], tet[s[1]], tet[s[2]]]);
            }
        }
    }
    out
}

/// Where the boundary is not a closed 2-manifold: edges not shared by exactly
/// two boundary triangles, and vertices whose boundary triangles form more
/// than one fan.
fn boundary_defects(mesh: &TetMesh, adj: &Adjacency) -> (Vec<[u32; 2]>, Vec<u32>) {
    let tris = boundary_triangles(mesh, adj);
    let mut edges: Vec<[u32; 2]> = Vec::with_capacity(tris.len() * 3);
    for t in &tris {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            edges.push([a.min(b), a.max(b)]);
        }
    }
    edges.sort_unstable();
    let mut bad_edges = Vec::new();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i != 2 {
            bad_edges.push(edges[i]);
        }
        i = j;
    }
    // Vertex links: for each boundary vertex, the opposite edges of its triangles.
    let mut link: Vec<(u32, u32, u32)> = Vec::with_capacity(tris.len() * 3);
    for t in &tris {
        link.push((t[0], t[1], t[2]));
        link.push((t[1], t[2], t[0]));
        link.push((t[2], t[0], t[1]));
    }
    link.sort_unstable();
    let mut bad_vertices = Vec::new();
    let mut i = 0;
    while i < link.len() {
        let mut j = i + 1;
        while j < link.len() && link[j].0 == link[i].0 {
            j += 1;
        }
        // Count connected components of the link graph.
        let pairs: Vec<(u32, u32)> = link[i..j].iter().map(|x| (x.1, x.2)).collect();
        let mut seen = vec![false; pairs.len()];
        let mut components = 0;
        for s in 0..pairs.len() {
            if seen[s] {
                continue;
            }
            components += 1;
            seen[s] = true;
            let mut stack = vec![s];
            while let Some(e) = stack.pop() {
                for f in 0..pairs.len() {
                    if !seen[f] {
                        let (a, b) = pairs[e];
                        let (c, d) = pairs[f];
                        if a == c || a == d || b == c || b == d {
                            seen[f] = true;
                            stack.push(f);
                        }
                    }
                }
            }
        }
        if components > 1 {
            bad_vertices.push(link[i].0);
        }
        i = j;
    }
    (bad_edges, bad_vertices)
}

/// Face-connected components: a component id per tetrahedron, numbered in
/// order of their first tetrahedron.
fn components(adj: &Adjacency) -> (Vec<u32>, usize) {
    let n = adj.neighbors.len();
    let mut comp = vec![u32::MAX; n];
    let mut count = 0;
    for s in 0..n {
        if comp[s] != u32::MAX {
            continue;
        }
        comp[s] = count as u32;
        let mut stack = vec![s];
        while let Some(t) = stack.pop() {
            for &nb in &adj.neighbors[t] {
                if nb != NO_NEIGHBOR && comp[nb as usize] == u32::MAX {
                    comp[nb as usize] = count as u32;
                    stack.push(nb as usize);
                }
            }
        }
        count += 1;
    }
    (comp, count)
}

// ---------------------------------------------------------------- quality

/// Smallest dihedral angle of a tetrahedron in degrees, or -1 when its signed
/// volume (VTK orientation) is not positive.
fn min_dihedral_deg(p: [V3; 4]) -> f64 {
    let vol6 = dot(sub(p[1], p[0]), cross(sub(p[2], p[0]), sub(p[3], p[0])));
    let scale_ref = {
        let l = norm(sub(p[1], p[0])).max(norm(sub(p[3], p[2])));
        l * l * l
    };
    if !(vol6 > 1e-9 * scale_ref) {
        return -1.0;
    }
    let mut n = [[0.0; 3]; 4];
    for (f, slots) in FACE_VERTICES.iter().enumerate() {
        let (a, b, c) = (p[slots[0]], p[slots[1]], p[slots[2]]);
        let mut nf = cross(sub(b, a), sub(c, a));
        if dot(nf, sub(p[f], a)) > 0.0 {
            nf = scale(nf, -1.0);
        }
        n[f] = normalize(nf);
    }
    let mut max_cos = -1.0f64;
    for i in 0..4 {
        for j in i + 1..4 {
            max_cos = max_cos.max(-dot(n[i], n[j]));
        }
    }
    max_cos.clamp(-1.0, 1.0).acos().to_degrees()
}

/// Vertex → incident tetrahedra, compressed.
struct Incidence {
    start: Vec<u32>,
    tets: Vec<u32>,
}

impl Incidence {
    fn new(mesh: &TetMesh) -> Incidence {
        let mut count = vec![0u32; mesh.points.len() + 1];
        for t in &mesh.tets {
            for &v in t {
                count[v as usize + 1] += 1;
            }
        }
        for i in 1..count.len() {
            count[i] += count[i - 1];
        }
        let mut fill = count.clone();
        let mut tets = vec![0u32; count[mesh.points.len()] as usize];
        for (t, tet) in mesh.tets.iter().enumerate() {
            for &v in tet {
                tets[fill[v as usize] as usize] = t as u32;
                fill[v as usize] += 1;
            }
        }
        Incidence { start: count, tets }
    }
    fn of(&self, v: usize) -> &[u32] {
        &self.tets[self.start[v] as usize..self.start[v + 1] as usize]
    }
}

/// Worst smallest-dihedral angle of the tetrahedra around `v` if `v` were at `q`.
fn worst_around(mesh: &TetMesh, inc: &Incidence, v: usize, q: V3) -> f64 {
    let mut worst = 180.0f64;
    for &t in inc.of(v) {
        let tet = mesh.tets[t as usize];
        let p = tet.map(|w| if w as usize == v { q } else { mesh.points[w as usize] });
        worst = worst.min(min_dihedral_deg(p));
    }
    worst
}

// ---------------------------------------------------------------- generation

/// Lattice spacing for about `cells` tetrahedra: `cells = 6 V (1 - c h) / h³`,
/// where `1 - c h` accounts for the boundary layer lost by keeping only the
/// tetrahedra with all four vertices inside (`c = 0.157 / mm`, measured).
fn spacing_for(geo: &Geometry, cells: usize) -> f64 {
    let v = geo.volume_estimate();
    let n = cells.max(100) as f64;
    let mut h = (6.0 * v / n).cbrt();
    for _ in 0..20 {
        h = (6.0 * v * (1.0 - 0.157 * h).max(0.2) / n).cbrt();
    }
    h
}

/// Generates the demo mesh (see the module documentation).
pub fn generate(p: &DemoParams) -> TetMesh {
    let h = spacing_for(&Geometry::new(BIG), p.cells_target);
    // Tubes farther than 3 h + the smooth-min radius are irrelevant to which
    // tetrahedra are kept and to the field blending.
    let geo = Geometry::new((3.0 * h + K_JUNCTION).max(BLEND + K_JUNCTION));

    // Lattice with one spacing of margin around the tubes.
    let (lo, hi) = geo.bounds();
    let origin = sub(lo, [1.5 * h; 3]);
    let n = [0, 1, 2].map(|k| ((hi[k] - lo[k] + 3.0 * h) / h).ceil() as usize + 1);
    let lat = Lattice { origin, h, n, templates: kuhn_templates() };
    let phi: Vec<f64> = (0..n[2])
        .into_par_iter()
        .flat_map_iter(|k| {
            let lat = &lat;
            let geo = &geo;
            (0..n[1]).flat_map(move |j| (0..n[0]).map(move |i| geo.phi(lat.pos(lat.vid(i, j, k)))))
        })
        .collect();

    // Keep tetrahedra whose mean vertex value is inside.
    let c = lat.cubes();
    let ntets = c[0] * c[1] * c[2] * 6;
    let mut keep: Vec<bool> = (0..ntets)
        .into_par_iter()
        .map(|t| lat.tet(t).iter().all(|&v| phi[v as usize] < 0.0))
        .collect();

    // Repair pinches and keep the largest component; then peel off the
    // tetrahedra whose four vertices all lie on the boundary (they would be
    // flattened by snapping), and repair again.
    let mut ex = clean(&lat, &mut keep);
    for _ in 0..3 {
        let adj = ex.mesh.adjacency();
        let mut on_boundary = vec![false; ex.mesh.points.len()];
        for tri in boundary_triangles(&ex.mesh, &adj) {
            for v in tri {
                on_boundary[v as usize] = true;
            }
        }
        let mut peeled = 0;
        for (i, tet) in ex.mesh.tets.iter().enumerate() {
            if tet.iter().all(|&v| on_boundary[v as usize]) && adj.neighbors[i].contains(&NO_NEIGHBOR) {
                keep[ex.lattice_tet[i]] = false;
                peeled += 1;
            }
        }
        if peeled == 0 {
            break;
        }
        ex = clean(&lat, &mut keep);
    }
    let Extracted { mut mesh, lattice_vertex, .. } = ex;
    let adj = mesh.adjacency();
    let nv = mesh.points.len();
    let mut on_boundary = vec![false; nv];
    for tri in boundary_triangles(&mesh, &adj) {
        for v in tri {
            on_boundary[v as usize] = true;
        }
    }
    relax(&mut mesh, &geo, &lattice_vertex, &lat, &on_boundary, p);
    mesh.fields = flow_fields(&mesh, &geo, &on_boundary, h);
    mesh
}

/// Repairs boundary pinches of the kept set (all lattice tetrahedra around a
/// bad edge or vertex are added or removed, by majority) and drops all but the
/// largest face-connected component; returns the extracted mesh.
fn clean(lat: &Lattice, keep: &mut [bool]) -> Extracted {
    let mut ex = extract(lat, keep);
    for _ in 0..50 {
        let adj = ex.mesh.adjacency();
        let (bad_e, bad_v) = boundary_defects(&ex.mesh, &adj);
        if bad_e.is_empty() && bad_v.is_empty() {
            break;
        }
        let mut groups: Vec<Vec<usize>> = Vec::new();
        for e in &bad_e {
            let a = lat.tets_around(ex.lattice_vertex[e[0] as usize]);
            let b = lat.tets_around(ex.lattice_vertex[e[1] as usize]);
            groups.push(a.into_iter().filter(|t| b.contains(t)).collect());
        }
        for &v in &bad_v {
            groups.push(lat.tets_around(ex.lattice_vertex[v as usize]));
        }
        for g in groups {
            let kept = g.iter().filter(|&&t| keep[t]).count();
            let fill = 2 * kept >= g.len();
            for t in g {
                keep[t] = fill;
            }
        }
        ex = extract(lat, keep);
    }
    let adj = ex.mesh.adjacency();
    let (comp, ncomp) = components(&adj);
    if ncomp > 1 {
        let mut size = vec![0usize; ncomp];
        for &c in &comp {
            size[c as usize] += 1;
        }
        let largest = (0..ncomp).max_by_key(|&c| (size[c], std::cmp::Reverse(c))).unwrap_or(0) as u32;
        for (i, &t) in ex.lattice_tet.iter().enumerate() {
            if comp[i] != largest {
                keep[t] = false;
            }
        }
        ex = extract(lat, keep);
    }
    ex
}

/// Moves boundary vertices onto the surface and smooths the interior layer
/// next to it, colour class by colour class (see the module documentation).
fn relax(mesh: &mut TetMesh, geo: &Geometry, lattice_vertex: &[usize], lat: &Lattice, on_boundary: &[bool], p: &DemoParams) {
    let nv = mesh.points.len();
    let inc = Incidence::new(mesh);
    let colour = |v: usize| {
        let [i, j, k] = lat.vijk(lattice_vertex[v]);
        (i & 1) | (j & 1) << 1 | (k & 1) << 2
    };
    let mut boundary_by_colour: Vec<Vec<usize>> = vec![Vec::new(); 8];
    let mut interior_by_colour: Vec<Vec<usize>> = vec![Vec::new(); 8];
    for v in 0..nv {
        if on_boundary[v] {
            boundary_by_colour[colour(v)].push(v);
        } else {
            interior_by_colour[colour(v)].push(v);
        }
    }
    // Surface targets, from the lattice positions.
    let mut target = vec![[0.0; 3]; nv];
    let bverts: Vec<usize> = (0..nv).filter(|&v| on_boundary[v]).collect();
    let projected: Vec<V3> = bverts.par_iter().map(|&v| geo.project(mesh.points[v], lat.h)).collect();
    for (&v, q) in bverts.iter().zip(projected) {
        target[v] = q;
    }
    let floor = p.quality_floor_deg;
    let adj = mesh.adjacency();
    let mut bnb: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for t in boundary_triangles(mesh, &adj) {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0]), (t[1], t[0]), (t[2], t[1]), (t[0], t[2])] {
            if !bnb[a as usize].contains(&b) {
                bnb[a as usize].push(b);
            }
        }
    }
    for pass in 0..p.relax_passes {
        // After the first pass, the target is the projection of the point
        // halfway to the mean of the boundary neighbours: snapping plus
        // tangential smoothing.
        if pass > 0 {
            let m: &TetMesh = mesh;
            let t: Vec<V3> = bverts.par_iter().map(|&v| {
                let mut c = [0.0; 3];
                for &w in &bnb[v] { c = add(c, m.points[w as usize]); }
                let c = scale(c, 1.0 / bnb[v].len() as f64);
                geo.project(lerp3(m.points[v], c, 0.5), lat.h)
            }).collect();
            for (&v, q) in bverts.iter().zip(t) { target[v] = q; }
        }
        for class in &boundary_by_colour {
            let m: &TetMesh = mesh;
            let moves: Vec<(usize, V3)> = class
                .par_iter()
                .filter_map(|&v| {
                    let cur = m.points[v];
                    let step = sub(target[v], cur);
                    if dot(step, step) < 1e-20 {
                        return None;
                    }
                    let old = worst_around(m, &inc, v, cur);
                    [1.0, 0.5, 0.25, 0.125].iter().find_map(|&a| {
                        let q = add(cur, scale(step, a));
                        let new = worst_around(m, &inc, v, q);
                        (new > 0.0 && new >= floor.min(old)).then_some((v, q))
                    })
                })
                .collect();
            for (v, q) in moves {
                mesh.points[v] = q;
            }
        }
        for class in &interior_by_colour {
            let m: &TetMesh = mesh;
            let moves: Vec<(usize, V3)> = class
                .par_iter()
                .filter_map(|&v| {
                    let cur = m.points[v];
                    let old = worst_around(m, &inc, v, cur);
                    if old >= 35.0 {
                        return None;
                    }
                    let ts = inc.of(v);
                    let mut c = [0.0; 3];
                    for &t in ts {
                        for w in m.tets[t as usize] {
                            c = add(c, m.points[w as usize]);
                        }
                    }
                    let q = scale(c, 1.0 / (4 * ts.len()) as f64);
                    let new = worst_around(m, &inc, v, q);
                    (new > old).then_some((v, q))
                })
                .collect();
            for (v, q) in moves {
                mesh.points[v] = q;
            }
        }
    }
}

/// `velocity`, `speed` and `pressure` at the vertices.
fn flow_fields(mesh: &TetMesh, geo: &Geometry, on_boundary: &[bool], h: f64) -> Vec<Field> {
    let samples: Vec<(V3, f64, f64)> = mesh.points.par_iter().map(|&p| geo.flow_at(p, 0.1 * h)).collect();
    let mut velocity = Vec::with_capacity(3 * samples.len());
    let mut speed = Vec::with_capacity(samples.len());
    let mut pressure = Vec::with_capacity(samples.len());
    for (i, (v, s, pr)) in samples.into_iter().enumerate() {
        velocity.extend_from_slice(&v);
        speed.push(if on_boundary[i] { 0.0 } else { s });
        pressure.push(pr);
    }
    vec![
        Field { name: "velocity".into(), components: 3, values: velocity },
        Field { name: "speed".into(), components: 1, values: speed },
        Field { name: "pressure".into(), components: 1, values: pressure },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats() {
        let t0 = std::time::Instant::now();
        let m = generate(&DemoParams::default());
        let dt = t0.elapsed();
        let adj = m.adjacency();
        let (be, bv) = boundary_defects(&m, &adj);
        let (_, nc) = components(&adj);
        let q: Vec<f64> = m.tets.iter().map(|t| min_dihedral_deg(t.map(|v| m.points[v as usize]))).collect();
        let mut qs = q.clone();
        qs.sort_by(f64::total_cmp);
        let vmin = (0..m.tets.len()).map(|t| m.tet_volume(t)).fold(f64::INFINITY, f64::min);
        eprintln!("time {dt:?} tets {} pts {} nonman {} bad e {} v {} comps {} vmin {vmin} dih min {} p1 {} p5 {} med {}",
            m.tets.len(), m.points.len(), adj.nonmanifold_faces, be.len(), bv.len(), nc, qs[0], qs[qs.len()/100], qs[qs.len()/20], qs[qs.len()/2]);
        let geo = Geometry::new(BIG);
        let tris = boundary_triangles(&m, &adj);
        let mut bvs: Vec<u32> = tris.iter().flatten().copied().collect();
        bvs.sort_unstable(); bvs.dedup();
        let errs: Vec<f64> = bvs.iter().map(|&v| geo.phi(m.points[v as usize]).abs()).collect();
        let h = spacing_for(&geo, 150_000);
        let far = errs.iter().filter(|&&e| e > 0.1 * h).count();
        let mut onb = vec![false; m.points.len()];
        for &v in &bvs { onb[v as usize] = true; }
        let inc = Incidence::new(&m);
        let stuck: Vec<u32> = bvs.iter().copied().filter(|&v| geo.phi(m.points[v as usize]).abs() > 0.1 * h).collect();
        let allb = stuck.iter().filter(|&&v| inc.of(v as usize).iter().any(|&t| m.tets[t as usize].iter().all(|&w| onb[w as usize]))).count();
        let nallb = m.tets.iter().filter(|t| t.iter().all(|&w| onb[w as usize])).count();
        let mut hist = [0usize; 8];
        for &v in &stuck { let e = geo.phi(m.points[v as usize]) / h; hist[((e + 1.0) * 4.0).clamp(0.0, 7.0) as usize] += 1; }
        eprintln!("stuck with all-boundary tet: {allb} of {}; all-boundary tets {nallb}; signed hist (-1..1 by .25) {hist:?}", stuck.len());
        eprintln!("h {h} boundary verts {} max |phi| {} >0.1h: {far}", bvs.len(), errs.iter().cloned().fold(0.0, f64::max));
    }
}
