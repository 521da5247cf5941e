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
//! 3. A tetrahedron is kept when all four of its vertices are inside. Any
//!    subset of a conforming mesh is conforming. Where the kept set pinches
//!    (a boundary edge with 4 boundary triangles, or a boundary vertex whose
//!    boundary triangles form two fans), the lattice tetrahedra around it are
//!    all added or all removed, by majority, until none is left; then only the
//!    largest face-connected component is kept. Tetrahedra whose four
//!    vertices all lie on the boundary (they would be flattened when their
//!    vertices reach a smooth surface) are peeled off, and the repair is
//!    repeated (up to 3 rounds).
//! 4. The staircase boundary is moved onto the surface. Each boundary
//!    vertex's target is its projection on the zero level set (two Newton
//!    steps); from the second pass on, the projection of the point halfway to
//!    the mean of its boundary neighbours (snapping plus tangential
//!    smoothing). A vertex takes the full step or the largest of 1/2, 1/4, 1/8
//!    of it that keeps the smallest dihedral angle of every incident
//!    tetrahedron at or above a floor (`quality_floor_deg`, default 15°), or
//!    not worse than it was. Then interior vertices next to the boundary whose
//!    worst incident tetrahedron is below 35° move to the mean of their
//!    incident tetrahedra's centroids when that improves it. 4 passes. No move
//!    is accepted that makes a volume non-positive.
//! 5. Vertices move in 8 colour classes (lattice index parity): two vertices
//!    of one class never share a tetrahedron, so each class moves in parallel
//!    with a result independent of the thread count. Nothing uses hashing or
//!    randomness, so the same parameters give a bit-identical mesh (tested,
//!    also against a 1-thread pool).
//!
//! Measured at the default target of 150 000 (the `print_statistics` test):
//! 150 365 tetrahedra, 30 474 vertices (9 957 on the wall), `h` = 1.17 mm;
//! tetrahedron volume min 0.0735 (0.046 h³), median 0.285, max 1.43 mm³;
//! smallest dihedral angle 15.6°, 1st percentile 25.0°, 5th 31.4°, median
//! 45°, 62 tetrahedra below 20°. 5 of the 9 957 wall vertices are more than
//! 0.1 h from the implicit surface (at most 0.47 h), the rest on it. The
//! boundary is a closed 2-manifold and the mesh one component. Generation
//! takes about 0.4–0.65 s in release on 2 shared cores (0.57 s on one thread).
//!
//! # Fields (at the vertices)
//!
//! - `velocity` (m/s): the cross-section mean velocity `Q(s) / (π r(s)²)`
//!   along the local centreline tangent, blended between tubes near the
//!   junctions with weights that fall to 0 over 4 mm of signed-distance
//!   difference. Inlet mean 0.4 m/s; the side branch takes 10 % of the
//!   flow, daughter A 50 %, daughter B 40 %.
//! - `speed` (m/s): `2 |velocity| (1 - (ρ/R)²)`, the Poiseuille profile, with
//!   `d` the distance to the wall (minus the signed distance), `ρ` the
//!   distance to the (blended) centreline and `R = d + ρ`; `d` ignores the
//!   inlet and outlet caps, and the speed is instead faded to 0 over the
//!   last 3 mm before each cap (smoothstep), so that it is 0 on every boundary
//!   vertex (unphysical at the caps, but smooth). It is exactly 0 on the
//!   boundary vertices and positive inside.
//! - `pressure` (Pa): Poiseuille pressure drop `dp/ds = -8 μ Q / (π r⁴)` with
//!   blood viscosity `μ = 3.5 mPa s`, integrated along each tube from the
//!   inlet, continuous at the junctions, shifted so that the lowest outlet is
//!   at 0. It falls along the flow.

use rayon::prelude::*;

use crate::data::mesh::{Adjacency, Field, TetMesh, FACE_VERTICES, NO_NEIGHBOR};
use crate::scene::TransferFunction;

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
        DemoParams {
            cells_target: 150_000,
            quality_floor_deg: 15.0,
            relax_passes: 4,
        }
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
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
fn normalize(a: V3) -> V3 {
    scale(a, 1.0 / norm(a))
}
fn lerp3(a: V3, b: V3, t: f64) -> V3 {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
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
/// Length over which speed fades to 0 at the inlet and outlet caps (mm).
const CAP_FADE: f64 = 3.0;
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
        add(
            scale(sub(c[1], c[0]), 3.0 * s * s),
            scale(sub(c[2], c[1]), 6.0 * s * t),
        ),
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
    /// Signed distance to the tube's wall (ignoring the end caps).
    wall: f64,
    /// Distance inside the open-end cap planes (`BIG` without open ends).
    cap: f64,
    /// Distance to the centreline.
    dist: f64,
    tangent: V3,
    radius: f64,
    flow: f64,
    pressure: f64,
}

const MISS: Hit = Hit {
    sdf: BIG,
    wall: BIG,
    cap: BIG,
    dist: BIG,
    tangent: [0.0; 3],
    radius: 1.0,
    flow: 0.0,
    pressure: 0.0,
};

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
            chunks.push(Chunk {
                first_seg: first,
                end_seg: end,
                lo: sub(lo, [m; 3]),
                hi: add(hi, [m; 3]),
            });
            first = end;
        }
        Tube {
            pts,
            tan,
            rad,
            arc,
            flow: vec![0.0; n],
            pres: vec![0.0; n],
            chunks,
            open_start,
            open_end,
        }
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
        let wall = dist - radius;
        let n = self.pts.len();
        let mut cap = BIG;
        if self.open_start {
            cap = cap.min(dot(sub(p, self.pts[0]), self.tan[0]));
        }
        if self.open_end {
            cap = cap.min(dot(sub(self.pts[n - 1], p), self.tan[n - 1]));
        }
        Hit {
            sdf: wall.max(-cap),
            wall,
            cap,
            dist,
            tangent: normalize(lerp3(self.tan[s], self.tan[s + 1], u)),
            radius,
            flow: lerp(self.flow[s], self.flow[s + 1], u),
            pressure: lerp(self.pres[s], self.pres[s + 1], u),
        }
    }

    /// Integrates the Poiseuille pressure drop from `p0` at the start.
    fn integrate_pressure(&mut self, p0: f64) {
        let g = |i: usize| {
            8.0 * MU * self.flow[i] / (std::f64::consts::PI * (self.rad[i] * 1e-3).powi(4))
        };
        let mut p = vec![p0; self.pts.len()];
        for i in 1..p.len() {
            let ds = (self.arc[i] - self.arc[i - 1]) * 1e-3;
            p[i] = p[i - 1] - 0.5 * (g(i - 1) + g(i)) * ds;
        }
        self.pres = p;
    }

    /// Pressure at arc length `s` (linear in between points).
    fn pressure_at_arc(&self, s: f64) -> f64 {
        let i = self
            .arc
            .partition_point(|&a| a <= s)
            .clamp(1, self.arc.len() - 1);
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
        let parent_ctrl = [
            [8.0, 0.0, -100.0],
            [-12.0, -6.0, -70.0],
            [0.0, 4.0, -35.0],
            [0.0, 0.0, 0.0],
        ];
        let o = bezier(&parent_ctrl, SIDE_T);
        let side_ctrl = [
            o,
            add(o, [10.0, -2.0, 3.0]),
            add(o, [22.0, -8.0, 12.0]),
            add(o, [30.0, -14.0, 26.0]),
        ];
        let mut parent = Tube::new(parent_ctrl, 10.0, 9.0, true, false, cull);
        let mut side = Tube::new(side_ctrl, 4.0, 3.5, false, true, cull);
        let mut da = Tube::new(
            [
                [0.0; 3],
                [8.0, 0.0, 18.0],
                [30.0, 6.0, 35.0],
                [42.0, 10.0, 72.0],
            ],
            7.0,
            6.0,
            false,
            true,
            cull,
        );
        let mut db = Tube::new(
            [
                [0.0; 3],
                [-8.0, 0.0, 18.0],
                [-28.0, -8.0, 38.0],
                [-34.0, -14.0, 75.0],
            ],
            6.0,
            5.0,
            false,
            true,
            cull,
        );

        // Flow rates (m³/s): the side branch takes 10 %, daughters 50 % and 40 %.
        let q_in = U_INLET * std::f64::consts::PI * (parent.rad[0] * 1e-3).powi(2);
        let (f_side, f_a, f_b) = (0.10, 0.50, 0.40);
        let side_arc = {
            let i = ((CENTRELINE_POINTS - 1) as f64 * SIDE_T).round() as usize;
            parent.arc[i]
        };
        let w = 2.0 * side.rad[0];
        parent.flow = parent
            .arc
            .iter()
            .map(|&s| q_in * (1.0 - f_side * smoothstep((s - side_arc) / w + 0.5)))
            .collect();
        side.flow = vec![f_side * q_in; CENTRELINE_POINTS];
        da.flow = vec![f_a * q_in; CENTRELINE_POINTS];
        db.flow = vec![f_b * q_in; CENTRELINE_POINTS];

        parent.integrate_pressure(0.0);
        side.integrate_pressure(parent.pressure_at_arc(side_arc));
        let pj = parent.pres[CENTRELINE_POINTS - 1];
        da.integrate_pressure(pj);
        db.integrate_pressure(pj);
        let mut tubes = [parent, side, da, db];
        let low = tubes
            .iter()
            .map(|t| t.pres[CENTRELINE_POINTS - 1])
            .fold(f64::INFINITY, f64::min);
        for t in &mut tubes {
            for p in &mut t.pres {
                *p -= low;
            }
        }
        Geometry { tubes }
    }

    fn hits(&self, p: V3) -> [Hit; 4] {
        [
            self.tubes[0].hit(p),
            self.tubes[1].hit(p),
            self.tubes[2].hit(p),
            self.tubes[3].hit(p),
        ]
    }

    fn phi_of(h: &[Hit; 4]) -> f64 {
        Self::merge([h[0].sdf, h[1].sdf, h[2].sdf, h[3].sdf])
    }

    /// The smooth union of the four tubes' signed distances.
    fn merge(d: [f64; 4]) -> f64 {
        let trunk = smin(d[PARENT], d[SIDE], K_SIDE);
        let crown = smin(d[DAUGHTER_A], d[DAUGHTER_B], K_CARINA);
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

    /// `(velocity, speed, pressure)` at `p`; `d_min` is the smallest wall and
    /// cap distance used for the no-slip profile (keeps interior vertices > 0).
    fn flow_at(&self, p: V3, d_min: f64) -> (V3, f64, f64) {
        let h = self.hits(p);
        let wall = Self::merge([h[0].wall, h[1].wall, h[2].wall, h[3].wall]);
        let smin_sdf = h.iter().map(|x| x.sdf).fold(f64::INFINITY, f64::min);
        let mut wsum = 0.0;
        let mut vel = [0.0; 3];
        let mut pres = 0.0;
        let mut rho = 0.0;
        let mut fade = 0.0;
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
            fade += w * smoothstep(x.cap.max(d_min) / CAP_FADE);
            wsum += w;
        }
        if wsum == 0.0 {
            return ([0.0; 3], 0.0, 0.0);
        }
        let vel = scale(vel, 1.0 / wsum);
        let rho = rho / wsum;
        let d = (-wall).max(d_min);
        let profile = (1.0 - (rho / (d + rho)).powi(2)) * fade / wsum;
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
                        let p = [
                            lo[0] + (i as f64 + 0.5) * step,
                            lo[1] + (j as f64 + 0.5) * step,
                            lo[2] + (k as f64 + 0.5) * step,
                        ];
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
    let mut out = [[[0usize; 3]; 4]; 6];
    for (m, p) in super::lattice::KUHN_AXIS_ORDERS.iter().enumerate() {
        let mut c1 = [0usize; 3];
        c1[p[0]] = 1;
        let mut c2 = c1;
        c2[p[1]] = 1;
        let odd = matches!(m, 1 | 2 | 5);
        out[m] = if odd {
            [[0; 3], c2, c1, [1; 3]]
        } else {
            [[0; 3], c1, c2, [1; 3]]
        };
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
        [
            v % self.n[0],
            (v / self.n[0]) % self.n[1],
            v / (self.n[0] * self.n[1]),
        ]
    }
    fn pos(&self, v: usize) -> V3 {
        let [i, j, k] = self.vijk(v);
        [
            self.origin[0] + i as f64 * self.h,
            self.origin[1] + j as f64 * self.h,
            self.origin[2] + k as f64 * self.h,
        ]
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
                    if i < di
                        || j < dj
                        || k < dk
                        || i - di >= c[0]
                        || j - dj >= c[1]
                        || k - dk >= c[2]
                    {
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
    let tets = lattice_tet
        .iter()
        .map(|&t| lat.tet(t).map(|v| map[v as usize]))
        .collect();
    let points = lattice_vertex.iter().map(|&v| lat.pos(v)).collect();
    Extracted {
        mesh: TetMesh {
            points,
            tets,
            fields: Vec::new(),
        },
        lattice_vertex,
        lattice_tet,
    }
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

/// Quality of a tetrahedron: `-cos` of its smallest dihedral angle (so it
/// grows with the angle, from -1 to 1), or -2 when its signed volume (VTK
/// orientation) is not positive.
fn tet_quality(p: [V3; 4]) -> f64 {
    let vol6 = dot(sub(p[1], p[0]), cross(sub(p[2], p[0]), sub(p[3], p[0])));
    let l = norm(sub(p[1], p[0])).max(norm(sub(p[3], p[2])));
    if vol6.is_nan() || vol6 <= 1e-9 * l * l * l {
        return -2.0;
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
    -max_cos.clamp(-1.0, 1.0)
}

/// Smallest dihedral angle of a tetrahedron in degrees, or -1 when its signed
/// volume is not positive.
#[cfg(test)]
fn min_dihedral_deg(p: [V3; 4]) -> f64 {
    let q = tet_quality(p);
    if q < -1.5 {
        -1.0
    } else {
        (-q).acos().to_degrees()
    }
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

/// Worst quality of the tetrahedra around `v` if `v` were at `q`.
fn worst_around(mesh: &TetMesh, inc: &Incidence, v: usize, q: V3) -> f64 {
    let mut worst = 1.0f64;
    for &t in inc.of(v) {
        let tet = mesh.tets[t as usize];
        let p = tet.map(|w| {
            if w as usize == v {
                q
            } else {
                mesh.points[w as usize]
            }
        });
        worst = worst.min(tet_quality(p));
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
    // The volume estimate only needs the sign, which culling at a margin of
    // K_JUNCTION (> every smooth-min bulge, k / 4) preserves.
    let h = spacing_for(&Geometry::new(K_JUNCTION), p.cells_target);
    // Tubes farther than 3 h + the smooth-min radius are irrelevant to which
    // tetrahedra are kept and to the field blending.
    let geo = Geometry::new((3.0 * h + K_JUNCTION).max(BLEND + K_JUNCTION));

    // Lattice with one spacing of margin around the tubes.
    let (lo, hi) = geo.bounds();
    let origin = sub(lo, [1.5 * h; 3]);
    let n = [0, 1, 2].map(|k| ((hi[k] - lo[k] + 3.0 * h) / h).ceil() as usize + 1);
    let lat = Lattice {
        origin,
        h,
        n,
        templates: kuhn_templates(),
    };
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
    let (mut ex, mut adj) = clean(&lat, &mut keep);
    for _ in 0..3 {
        let mut on_boundary = vec![false; ex.mesh.points.len()];
        for tri in boundary_triangles(&ex.mesh, &adj) {
            for v in tri {
                on_boundary[v as usize] = true;
            }
        }
        let mut peeled = 0;
        for (i, tet) in ex.mesh.tets.iter().enumerate() {
            if tet.iter().all(|&v| on_boundary[v as usize])
                && adj.neighbors[i].contains(&NO_NEIGHBOR)
            {
                keep[ex.lattice_tet[i]] = false;
                peeled += 1;
            }
        }
        if peeled == 0 {
            break;
        }
        (ex, adj) = clean(&lat, &mut keep);
    }
    let Extracted {
        mut mesh,
        lattice_vertex,
        ..
    } = ex;
    let nv = mesh.points.len();
    let tris = boundary_triangles(&mesh, &adj);
    let mut on_boundary = vec![false; nv];
    for tri in &tris {
        for &v in tri {
            on_boundary[v as usize] = true;
        }
    }
    relax(
        &mut mesh,
        &geo,
        &lattice_vertex,
        &lat,
        &on_boundary,
        &tris,
        p,
    );
    mesh.fields = flow_fields(&mesh, &geo, &on_boundary, h);
    mesh
}

/// Repairs boundary pinches of the kept set (all lattice tetrahedra around a
/// bad edge or vertex are added or removed, by majority) and drops all but the
/// largest face-connected component; returns the extracted mesh.
fn clean(lat: &Lattice, keep: &mut [bool]) -> (Extracted, Adjacency) {
    let mut ex = extract(lat, keep);
    let mut adj = ex.mesh.adjacency();
    for _ in 0..50 {
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
        adj = ex.mesh.adjacency();
    }
    let (comp, ncomp) = components(&adj);
    if ncomp > 1 {
        let mut size = vec![0usize; ncomp];
        for &c in &comp {
            size[c as usize] += 1;
        }
        let largest = (0..ncomp)
            .max_by_key(|&c| (size[c], std::cmp::Reverse(c)))
            .unwrap_or(0) as u32;
        for (i, &t) in ex.lattice_tet.iter().enumerate() {
            if comp[i] != largest {
                keep[t] = false;
            }
        }
        ex = extract(lat, keep);
        adj = ex.mesh.adjacency();
    }
    (ex, adj)
}

/// Moves boundary vertices onto the surface and smooths the interior layer
/// next to it, colour class by colour class (see the module documentation).
fn relax(
    mesh: &mut TetMesh,
    geo: &Geometry,
    lattice_vertex: &[usize],
    lat: &Lattice,
    on_boundary: &[bool],
    tris: &[[u32; 3]],
    p: &DemoParams,
) {
    let nv = mesh.points.len();
    let inc = Incidence::new(mesh);
    // Interior vertices that share a tetrahedron with a boundary vertex.
    let mut band = vec![false; nv];
    for t in &mesh.tets {
        if t.iter().any(|&v| on_boundary[v as usize]) {
            for &v in t {
                band[v as usize] = !on_boundary[v as usize];
            }
        }
    }
    let colour = |v: usize| {
        let [i, j, k] = lat.vijk(lattice_vertex[v]);
        (i & 1) | (j & 1) << 1 | (k & 1) << 2
    };
    let mut boundary_by_colour: Vec<Vec<usize>> = vec![Vec::new(); 8];
    let mut band_by_colour: Vec<Vec<usize>> = vec![Vec::new(); 8];
    for v in 0..nv {
        if on_boundary[v] {
            boundary_by_colour[colour(v)].push(v);
        } else if band[v] {
            band_by_colour[colour(v)].push(v);
        }
    }
    // Boundary neighbours, from the boundary triangles.
    let mut bnb: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for t in tris {
        for (a, b) in [
            (t[0], t[1]),
            (t[1], t[2]),
            (t[2], t[0]),
            (t[1], t[0]),
            (t[2], t[1]),
            (t[0], t[2]),
        ] {
            if !bnb[a as usize].contains(&b) {
                bnb[a as usize].push(b);
            }
        }
    }
    let bverts: Vec<usize> = (0..nv).filter(|&v| on_boundary[v]).collect();
    let mut target = vec![[0.0; 3]; nv];
    let mut quality: Vec<f64> = mesh
        .tets
        .par_iter()
        .map(|t| tet_quality(t.map(|v| mesh.points[v as usize])))
        .collect();
    let floor = -p.quality_floor_deg.to_radians().cos();
    let smooth_below = -35f64.to_radians().cos();

    // Applies one colour class's moves and refreshes the cached qualities.
    let apply = |mesh: &mut TetMesh, quality: &mut Vec<f64>, moves: Vec<(usize, V3)>| {
        for &(v, q) in &moves {
            mesh.points[v] = q;
        }
        for &(v, _) in &moves {
            for &t in inc.of(v) {
                quality[t as usize] =
                    tet_quality(mesh.tets[t as usize].map(|w| mesh.points[w as usize]));
            }
        }
    };
    let worst_cached = |quality: &[f64], v: usize| {
        inc.of(v)
            .iter()
            .map(|&t| quality[t as usize])
            .fold(1.0, f64::min)
    };

    for pass in 0..p.relax_passes {
        // Targets: the projection of the vertex itself (first pass), then of
        // the point halfway to the mean of its boundary neighbours: snapping
        // plus tangential smoothing.
        let m: &TetMesh = mesh;
        let targets: Vec<V3> = bverts
            .par_iter()
            .map(|&v| {
                if pass == 0 {
                    return geo.project(m.points[v], lat.h);
                }
                let mut c = [0.0; 3];
                for &w in &bnb[v] {
                    c = add(c, m.points[w as usize]);
                }
                let c = scale(c, 1.0 / bnb[v].len() as f64);
                geo.project(lerp3(m.points[v], c, 0.5), lat.h)
            })
            .collect();
        for (&v, q) in bverts.iter().zip(targets) {
            target[v] = q;
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
                    let old = worst_cached(&quality, v);
                    [1.0, 0.5, 0.25, 0.125].iter().find_map(|&a| {
                        let q = add(cur, scale(step, a));
                        let new = worst_around(m, &inc, v, q);
                        (new > -1.5 && new >= floor.min(old)).then_some((v, q))
                    })
                })
                .collect();
            apply(mesh, &mut quality, moves);
        }
        for class in &band_by_colour {
            let m: &TetMesh = mesh;
            let moves: Vec<(usize, V3)> = class
                .par_iter()
                .filter_map(|&v| {
                    let old = worst_cached(&quality, v);
                    if old >= smooth_below {
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
                    (worst_around(m, &inc, v, q) > old).then_some((v, q))
                })
                .collect();
            apply(mesh, &mut quality, moves);
        }
    }
}

/// `velocity`, `speed` and `pressure` at the vertices.
fn flow_fields(mesh: &TetMesh, geo: &Geometry, on_boundary: &[bool], h: f64) -> Vec<Field> {
    let samples: Vec<(V3, f64, f64)> = mesh
        .points
        .par_iter()
        .map(|&p| geo.flow_at(p, 0.1 * h))
        .collect();
    let mut velocity = Vec::with_capacity(3 * samples.len());
    let mut speed = Vec::with_capacity(samples.len());
    let mut pressure = Vec::with_capacity(samples.len());
    for (i, (v, s, pr)) in samples.into_iter().enumerate() {
        velocity.extend_from_slice(&v);
        speed.push(if on_boundary[i] { 0.0 } else { s });
        pressure.push(pr);
    }
    vec![
        Field {
            name: "velocity".into(),
            components: 3,
            values: velocity,
        },
        Field {
            name: "speed".into(),
            components: 1,
            values: speed,
        },
        Field {
            name: "pressure".into(),
            components: 1,
            values: pressure,
        },
    ]
}

// ---------------------------------------------------------------- scene

/// Image size of the demo scene.
const IMAGE: (u32, u32) = (512, 384);

/// ParaView's "Cool to Warm" map, piecewise linear through five of its colours.
fn cool_to_warm(s: f64) -> V3 {
    const C: [V3; 5] = [
        [0.230, 0.299, 0.754],
        [0.552, 0.690, 0.996],
        [0.865, 0.865, 0.865],
        [0.958, 0.604, 0.482],
        [0.706, 0.016, 0.150],
    ];
    let x = s.clamp(0.0, 1.0) * 4.0;
    let i = (x.floor() as usize).min(3);
    lerp3(C[i], C[i + 1], x - i as f64)
}

/// Opacity control points `(s, opacity)`: 0 at rest, high over the slow
/// near-wall shell, translucent in the middle, rising again for the fastest
/// cores (the shape of the aorta scenes' function).
const OPACITY: [(f64, f64); 8] = [
    (0.0, 0.0),
    (0.04, 0.2),
    (0.10, 0.65),
    (0.24, 0.65),
    (0.34, 0.3),
    (0.5, 0.08),
    (0.75, 0.12),
    (1.0, 0.24),
];

fn demo_transfer(unit_distance: f64) -> TransferFunction {
    use crate::scene::ControlPoint;
    let points = OPACITY
        .iter()
        .map(|&(s, opacity)| ControlPoint {
            s,
            rgb: cool_to_warm(s),
            opacity,
        })
        .collect();
    TransferFunction {
        points,
        unit_distance,
    }
}

/// `sum of -ln(1 - opacity) dt` along a straight ray through `c` in direction
/// `dir` (the optical depth times `unit_distance`), and the lumen length crossed.
fn optical_depth(
    geo: &Geometry,
    tf: &TransferFunction,
    range: [f64; 2],
    c: V3,
    dir: V3,
    half: f64,
) -> (f64, f64) {
    let dt = 0.05;
    let n = (2.0 * half / dt) as usize;
    let (mut depth, mut len) = (0.0, 0.0);
    for i in 0..n {
        let p = add(c, scale(dir, -half + (i as f64 + 0.5) * dt));
        if geo.phi(p) >= 0.0 {
            continue;
        }
        let (_, speed, _) = geo.flow_at(p, 0.0);
        let s = (speed - range[0]) / (range[1] - range[0]);
        let o = tf.eval(s).1.min(crate::scene::transfer::OPACITY_MAX);
        depth += -(1.0 - o).ln() * dt;
        len += dt;
    }
    (depth, len)
}

/// Scene TOML (`shared/spec/scene.md`) for the demo mesh: field `speed`, an
/// orthographic camera looking along +y at the bifurcation plane (image
/// right = +z, the flow direction; image up = -x), fitted to the mesh bounds
/// with a 5 % margin, 512 x 384, black background, a cool-to-warm transfer
/// function, and `unit_distance` chosen so that a ray across the parent vessel
/// reaches alpha 0.9. A comment block at the top explains the choices.
pub fn demo_scene_toml(data_file_name: &str, mesh: &TetMesh) -> String {
    let (lo, hi) = mesh.bounds();
    let centre = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let ext = sub(hi, lo);
    let (w, h) = IMAGE;
    // right = +z, screen up = -x: the projected box is ext[2] wide, ext[0] high.
    let (pw, ph) = (ext[2] * 1.1, ext[0] * 1.1);
    let height = ((ph.max(pw * h as f64 / w as f64)) * 100.0).ceil() / 100.0;
    let r3 = |x: f64| (x * 1000.0).round() / 1000.0;
    let target = centre.map(r3);
    let eye = [target[0], r3(lo[1] - ext[1] - 100.0), target[2]];

    let speed = mesh.scalar("speed").unwrap_or_default();
    let range = [
        speed.iter().cloned().fold(f64::INFINITY, f64::min),
        speed.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
    ];
    let range = if range[0] < range[1] {
        range
    } else {
        [0.0, 1.0]
    };

    // unit_distance: alpha 0.9 across the parent vessel (a quarter along it,
    // upstream of the side branch), along the view direction.
    let geo = Geometry::new(BIG);
    let tf1 = demo_transfer(1.0);
    let y = [0.0, 1.0, 0.0];
    let probe = |tube: usize, t: f64| {
        let tb = &geo.tubes[tube];
        let i = ((tb.pts.len() - 1) as f64 * t).round() as usize;
        optical_depth(&geo, &tf1, range, tb.pts[i], y, tb.rad[i] * 2.0 + 2.0)
    };
    let (parent_depth, _) = probe(PARENT, 0.25);
    let ud_exact = parent_depth / 10f64.ln();
    // Two significant digits, printed exactly as used.
    let ud: f64 = {
        let decimals = (1.0 - ud_exact.log10().floor()).max(0.0) as usize;
        format!("{ud_exact:.decimals$}").parse().unwrap_or(ud_exact)
    };
    let tf = demo_transfer(ud);
    let alpha = |(depth, len): (f64, f64)| (1.0 - (-depth / ud).exp(), len);
    let probes = [
        (
            "parent (r = 10 -> 9 mm), a quarter along it",
            probe(PARENT, 0.25),
        ),
        ("parent just before the junction", probe(PARENT, 0.9)),
        (
            "daughter A (r = 7 -> 6 mm), halfway",
            probe(DAUGHTER_A, 0.5),
        ),
        (
            "daughter B (r = 6 -> 5 mm), halfway",
            probe(DAUGHTER_B, 0.5),
        ),
        ("side branch (r = 4 -> 3.5 mm), halfway", probe(SIDE, 0.5)),
    ];
    let mean_opacity = speed
        .iter()
        .map(|&v| tf.eval((v - range[0]) / (range[1] - range[0])).1)
        .sum::<f64>()
        / speed.len().max(1) as f64;
    let wall = speed.iter().filter(|&&v| v == 0.0).count();

    let mut s = String::new();
    s += "# pvrsim demo: a synthetic arterial bifurcation (generated by pvrsim, not patient data), mm and m/s.\n";
    s += &format!(
        "# Data: {data_file_name}, {} tetrahedra, {} vertices; speed = 2 |velocity| (1 - (rho/R)^2) (Poiseuille-like,\n",
        mesh.tets.len(),
        mesh.points.len()
    );
    s += &format!(
        "# 0 on the {wall} wall vertices); range = the field's min..max, [{:.4}, {:.4}] m/s.\n",
        range[0], range[1]
    );
    s += "# Camera: orthographic, looking along +y at the bifurcation plane: image right = +z (the flow runs left to right,\n";
    s += "# inlet at the left, outlets at the right), image up = -x (daughter B above, daughter A and the side branch below).\n";
    s += &format!(
        "# Fitted to the mesh bounding box with a 5% margin on each side (projected extent {:.1} x {:.1} mm).\n",
        ext[2], ext[0]
    );
    s += "# Transfer function: colours blue -> red (ParaView 'Cool to Warm'); opacity rises fast from 0 at the wall,\n";
    s += "# is high for slow flow (the near-wall shell, s 0.10-0.24), translucent around s = 0.5 and rises again to 0.24\n";
    s += "# for the fastest cores, as in the aorta scenes.\n";
    s += &format!(
        "# Mean TF opacity over all {} vertices = {mean_opacity:.4}.\n",
        speed.len()
    );
    s += &format!(
        "# unit_distance = {ud} mm, so that a ray across the parent vessel along the view direction reaches alpha 0.9\n"
    );
    s += "# (exact value for that: ";
    s += &format!(
        "{ud_exact:.3} mm). Accumulated alpha along such rays (analytic field, 0.05 mm steps):\n"
    );
    for (name, d) in probes {
        let (a, len) = alpha(d);
        s += &format!("#   {name}: {a:.3} over {len:.1} mm of lumen\n");
    }
    s += "\n[data]\n";
    s += &format!("path  = {data_file_name:?}\nfield = \"speed\"\n");
    s += "\n[camera]\n";
    let v = |p: V3| format!("[{}, {}, {}]", p[0], p[1], p[2]);
    s += &format!(
        "eye        = {}\ntarget     = {}\nup         = [-1, 0, 0]\n",
        v(eye),
        v(target)
    );
    s += &format!("projection = \"orthographic\"\nheight     = {height}\n");
    s += &format!("\n[image]\nwidth      = {w}\nheight     = {h}\nbackground = [0, 0, 0]\n");
    s += &format!("\n[transfer]\nunit_distance = {ud}\npoints = [\n");
    for p in &tf.points {
        s += &format!(
            "  [{:.4}, {:.4}, {:.4}, {:.4}, {:.4}],\n",
            p.s, p.rgb[0], p.rgb[1], p.rgb[2], p.opacity
        );
    }
    s += "]\n";
    s
}

/// The demo mesh and its scene text (see [`generate`] and [`demo_scene_toml`]).
pub fn demo_mesh_and_scene(p: &DemoParams, data_file_name: &str) -> (TetMesh, String) {
    let mesh = generate(p);
    let scene = demo_scene_toml(data_file_name, &mesh);
    (mesh, scene)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;
    use std::sync::OnceLock;

    /// The default mesh, generated once for all tests.
    fn mesh() -> &'static TetMesh {
        static MESH: OnceLock<TetMesh> = OnceLock::new();
        MESH.get_or_init(|| generate(&DemoParams::default()))
    }

    fn boundary_flags(m: &TetMesh) -> Vec<bool> {
        let mut b = vec![false; m.points.len()];
        for t in boundary_triangles(m, &m.adjacency()) {
            for v in t {
                b[v as usize] = true;
            }
        }
        b
    }

    fn field<'a>(m: &'a TetMesh, name: &str) -> &'a Field {
        m.fields.iter().find(|f| f.name == name).unwrap()
    }

    /// Unique edges of the mesh.
    fn edges(m: &TetMesh) -> Vec<[u32; 2]> {
        let mut e: Vec<[u32; 2]> = m
            .tets
            .iter()
            .flat_map(|t| {
                [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
                    .map(|(a, b)| [t[a].min(t[b]), t[a].max(t[b])])
            })
            .collect();
        e.sort_unstable();
        e.dedup();
        e
    }

    #[test]
    fn deterministic_across_runs_and_thread_counts() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let again = pool.install(|| generate(&DemoParams::default()));
        let a = mesh();
        assert_eq!(a.tets, again.tets);
        let bits = |m: &TetMesh| {
            m.points
                .iter()
                .flatten()
                .map(|x| x.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(a), bits(&again));
        for (f, g) in a.fields.iter().zip(&again.fields) {
            assert_eq!(f.name, g.name);
            assert!(
                f.values
                    .iter()
                    .zip(&g.values)
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
                "field {}",
                f.name
            );
        }
    }

    #[test]
    fn valid_conforming_mesh() {
        let m = mesh();
        m.validate(std::path::Path::new("demo")).unwrap();
        let adj = m.adjacency();
        assert_eq!(adj.nonmanifold_faces, 0);
        let (bad_edges, bad_vertices) = boundary_defects(m, &adj);
        assert!(
            bad_edges.is_empty() && bad_vertices.is_empty(),
            "boundary not a closed manifold: {} edges, {} vertices",
            bad_edges.len(),
            bad_vertices.len()
        );
        assert_eq!(components(&adj).1, 1, "one connected component");
        // Every point is used.
        let mut used = vec![false; m.points.len()];
        m.tets
            .iter()
            .flatten()
            .for_each(|&v| used[v as usize] = true);
        assert!(used.iter().all(|&u| u));
        // Orientation and shape.
        let h = spacing_for(
            &Geometry::new(K_JUNCTION),
            DemoParams::default().cells_target,
        );
        let vmin = (0..m.tets.len())
            .map(|t| m.tet_volume(t))
            .fold(f64::INFINITY, f64::min);
        assert!(vmin > 0.01 * h * h * h, "min volume {vmin} (h = {h})");
        let dmin = m
            .tets
            .iter()
            .map(|t| min_dihedral_deg(t.map(|v| m.points[v as usize])))
            .fold(180.0, f64::min);
        assert!(
            dmin >= DemoParams::default().quality_floor_deg - 1e-6,
            "min dihedral {dmin}"
        );
    }

    #[test]
    fn cell_count_scales_with_the_target() {
        let n = mesh().tets.len();
        assert!((100_000..=300_000).contains(&n), "{n} tetrahedra");
        assert!(
            (n as f64 / 150_000.0 - 1.0).abs() < 0.1,
            "{n} tetrahedra for a target of 150000"
        );
        let small = generate(&DemoParams {
            cells_target: 20_000,
            ..Default::default()
        });
        let r = small.tets.len() as f64 / 20_000.0;
        assert!(
            (0.75..1.25).contains(&r),
            "{} tetrahedra for a target of 20000",
            small.tets.len()
        );
        assert_eq!(small.adjacency().nonmanifold_faces, 0);
        assert_eq!(components(&small.adjacency()).1, 1);
    }

    #[test]
    fn boundary_lies_on_the_surface() {
        let m = mesh();
        let geo = Geometry::new(BIG);
        let h = spacing_for(&geo, DemoParams::default().cells_target);
        let b = boundary_flags(m);
        let err: Vec<f64> = (0..m.points.len())
            .filter(|&v| b[v])
            .map(|v| geo.phi(m.points[v]).abs())
            .collect();
        let off = err.iter().filter(|&&e| e > 0.1 * h).count();
        let max = err.iter().cloned().fold(0.0, f64::max);
        assert!(
            off * 100 < err.len(),
            "{off} of {} boundary vertices more than 0.1 h off the surface",
            err.len()
        );
        assert!(max < 0.6 * h, "max distance {max}");
    }

    #[test]
    fn fields_are_flow_like() {
        let m = mesh();
        let b = boundary_flags(m);
        let speed = &field(m, "speed").values;
        let vel = &field(m, "velocity").values;
        let pres = &field(m, "pressure").values;
        assert_eq!(field(m, "velocity").components, 3);
        for v in 0..m.points.len() {
            if b[v] {
                assert_eq!(speed[v], 0.0, "wall vertex {v}");
            } else {
                assert!(speed[v] > 0.0, "interior vertex {v}");
            }
        }
        let smax = speed.iter().cloned().fold(0.0, f64::max);
        assert!((0.5..3.0).contains(&smax), "max speed {smax}");
        // Smooth: no jump between neighbours beyond the steepest analytic slope
        // (the wall shear of the side branch, about 0.4 m/s per mm).
        for [a, c] in edges(m) {
            let (a, c) = (a as usize, c as usize);
            let len = norm(sub(m.points[a], m.points[c]));
            assert!(
                (speed[a] - speed[c]).abs() <= 0.6 * len,
                "speed jump on edge {a}-{c}"
            );
            let dv = norm(sub(
                [vel[3 * a], vel[3 * a + 1], vel[3 * a + 2]],
                [vel[3 * c], vel[3 * c + 1], vel[3 * c + 2]],
            ));
            assert!(dv <= 0.2 * len, "velocity jump {dv} on edge {a}-{c}");
        }
        // Flow follows the centrelines, and pressure falls along it.
        let geo = Geometry::new(BIG);
        for (k, tube) in geo.tubes.iter().enumerate() {
            // Branch starts lie inside the parent, where the flows blend.
            let first = if k == PARENT {
                2
            } else {
                CENTRELINE_POINTS / 2
            };
            for i in [first, CENTRELINE_POINTS / 2, CENTRELINE_POINTS - 6] {
                let (v, s, _) = geo.flow_at(tube.pts[i], 0.0);
                assert!(
                    dot(v, tube.tan[i]) > 0.9 * norm(v),
                    "velocity along the centreline"
                );
                assert!(s > 0.2);
            }
            assert!(
                tube.pres.windows(2).all(|w| w[1] < w[0]),
                "pressure falls along each tube"
            );
        }
        let pmin = pres.iter().cloned().fold(f64::INFINITY, f64::min);
        let pmax = pres.iter().cloned().fold(0.0, f64::max);
        assert!(
            pmin > -1e-9 && pmax > 1.0,
            "pressure range [{pmin}, {pmax}]"
        );
        // The inlet (z lowest) has the highest pressure.
        let inlet = (0..m.points.len())
            .min_by(|&a, &c| m.points[a][2].total_cmp(&m.points[c][2]))
            .unwrap();
        assert!(pres[inlet] > 0.95 * pmax);
    }

    #[test]
    fn scene_parses_and_sees_the_whole_mesh() {
        let m = mesh();
        let text = demo_scene_toml("demo.vtk", m);
        let scene = Scene::parse(&text, std::path::Path::new("data/demo.toml")).unwrap();
        assert_eq!(scene.data.field, "speed");
        assert_eq!(scene.data.path, std::path::Path::new("data/demo.vtk"));
        assert!(text.starts_with("# "));
        let view = scene.view();
        let (lo, hi) = m.bounds();
        let (mut xmin, mut xmax, mut ymin, mut ymax) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for c in 0..8 {
            let p = [
                if c & 1 == 0 { lo[0] } else { hi[0] },
                if c & 2 == 0 { lo[1] } else { hi[1] },
                if c & 4 == 0 { lo[2] } else { hi[2] },
            ];
            let cam = view.to_camera(p);
            assert!(cam[2] > 0.0, "corner in front of the eye");
            let [x, y] = view.camera_to_pixel(cam).unwrap();
            assert!(
                x > 0.0 && x < scene.image.width as f64 && y > 0.0 && y < scene.image.height as f64,
                "corner {p:?} at pixel ({x}, {y})"
            );
            (xmin, xmax, ymin, ymax) = (xmin.min(x), xmax.max(x), ymin.min(y), ymax.max(y));
        }
        // Fitted: the box fills the image in at least one direction, up to the margin.
        let fill = ((xmax - xmin) / scene.image.width as f64)
            .max((ymax - ymin) / scene.image.height as f64);
        assert!(fill > 0.85, "box fills {fill} of the image");
        // unit_distance gives alpha about 0.9 across the parent.
        let speed = m.scalar("speed").unwrap();
        let range = [0.0, speed.iter().cloned().fold(0.0, f64::max)];
        let geo = Geometry::new(BIG);
        let t = &geo.tubes[PARENT];
        let i = (CENTRELINE_POINTS - 1) / 4;
        let (depth, _) = optical_depth(
            &geo,
            &scene.transfer,
            range,
            t.pts[i],
            [0.0, 1.0, 0.0],
            2.0 * t.rad[i] + 2.0,
        );
        let alpha = 1.0 - (-depth / scene.transfer.unit_distance).exp();
        assert!(
            (0.85..0.95).contains(&alpha),
            "alpha across the parent {alpha}"
        );
    }

    /// Prints the mesh statistics (`cargo test --release --lib data::demo -- --nocapture`).
    #[test]
    fn print_statistics() {
        let t0 = std::time::Instant::now();
        let m = generate(&DemoParams::default());
        let dt = t0.elapsed();
        let mut q: Vec<f64> = m
            .tets
            .iter()
            .map(|t| min_dihedral_deg(t.map(|v| m.points[v as usize])))
            .collect();
        q.sort_by(f64::total_cmp);
        let mut vol: Vec<f64> = (0..m.tets.len()).map(|t| m.tet_volume(t)).collect();
        vol.sort_by(f64::total_cmp);
        let wall = boundary_flags(&m).iter().filter(|&&b| b).count();
        let n = q.len();
        eprintln!(
            "demo mesh: generated in {dt:.2?}; {} tetrahedra, {} vertices ({wall} on the wall); volume min {:.4} median {:.4} max {:.4} mm3, total {:.0} mm3; \
             min dihedral {:.2} deg, 1st pct {:.2}, 5th pct {:.2}, median {:.2}; below 20 deg: {}",
            n,
            m.points.len(),
            vol[0],
            vol[n / 2],
            vol[n - 1],
            vol.iter().sum::<f64>(),
            q[0],
            q[n / 100],
            q[n / 20],
            q[n / 2],
            q.iter().filter(|&&a| a < 20.0).count()
        );
    }
}
