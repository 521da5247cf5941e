//! The demo's solid: four tapered Bézier tubes merged by a smooth minimum,
//! their signed distance, and the flow quantities along each centreline.

use super::*;

/// "Far" signed distance for tubes culled as irrelevant.
pub(super) const BIG: f64 = 1e9;
/// Blood viscosity, Pa s.
pub(super) const MU: f64 = 3.5e-3;
/// Mean inlet velocity, m/s.
pub(super) const U_INLET: f64 = 0.4;
/// Points per centreline polyline.
pub(super) const CENTRELINE_POINTS: usize = 48;
/// Segments per culling chunk.
pub(super) const CHUNK: usize = 6;
/// Length over which speed fades to 0 at the inlet and outlet caps (mm).
pub(super) const CAP_FADE: f64 = 3.0;
/// Field-blending width (mm of signed-distance difference).
pub(super) const BLEND: f64 = 4.0;
pub(super) const K_JUNCTION: f64 = 4.0;
pub(super) const K_CARINA: f64 = 3.0;
pub(super) const K_SIDE: f64 = 2.0;

pub(super) const PARENT: usize = 0;
pub(super) const SIDE: usize = 1;
pub(super) const DAUGHTER_A: usize = 2;
pub(super) const DAUGHTER_B: usize = 3;

pub(super) fn bezier(c: &[V3; 4], t: f64) -> V3 {
    let s = 1.0 - t;
    let w = [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t];
    let mut p = [0.0; 3];
    for (ci, wi) in c.iter().zip(w) {
        p = add(p, scale(*ci, wi));
    }
    p
}
pub(super) fn bezier_tangent(c: &[V3; 4], t: f64) -> V3 {
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
pub(super) struct Chunk {
    pub(super) first_seg: usize,
    pub(super) end_seg: usize,
    pub(super) lo: V3,
    pub(super) hi: V3,
}

/// One vessel: a centreline polyline with radius, flow rate and pressure per point.
#[derive(Debug, Clone)]
pub(super) struct Tube {
    pub(super) pts: Vec<V3>,
    pub(super) tan: Vec<V3>,
    pub(super) rad: Vec<f64>,
    pub(super) arc: Vec<f64>,
    pub(super) flow: Vec<f64>,
    pub(super) pres: Vec<f64>,
    pub(super) chunks: Vec<Chunk>,
    /// Per segment: its vector and that vector's squared length.
    pub(super) segs: Vec<(V3, f64)>,
    pub(super) open_start: bool,
    pub(super) open_end: bool,
    /// Chunk boxes reach this far beyond the centreline plus radius.
    pub(super) cull: f64,
    /// Smallest and largest radius.
    pub(super) rmin: f64,
    pub(super) rmax: f64,
}

/// What one tube says about a point.
#[derive(Debug, Clone, Copy)]
pub(super) struct Hit {
    /// Signed distance to this tube's surface (`BIG` when culled).
    pub(super) sdf: f64,
    /// Signed distance to the tube's wall (ignoring the end caps).
    pub(super) wall: f64,
    /// Distance inside the open-end cap planes (`BIG` without open ends).
    pub(super) cap: f64,
    /// Distance to the centreline.
    pub(super) dist: f64,
    pub(super) tangent: V3,
    pub(super) radius: f64,
    pub(super) flow: f64,
    pub(super) pressure: f64,
}

pub(super) const MISS: Hit = Hit {
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
    pub(super) fn new(
        ctrl: [V3; 4],
        r0: f64,
        r1: f64,
        open_start: bool,
        open_end: bool,
        cull: f64,
    ) -> Tube {
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
        let segs = (0..n - 1)
            .map(|s| {
                let ab = sub(pts[s + 1], pts[s]);
                (ab, dot(ab, ab))
            })
            .collect();
        Tube {
            pts,
            tan,
            rad,
            arc,
            flow: vec![0.0; n],
            pres: vec![0.0; n],
            chunks,
            segs,
            open_start,
            open_end,
            cull,
            rmin: r0.min(r1),
            rmax: r0.max(r1),
        }
    }

    /// A lower bound of `sdf - |q - p|` at every point `q`, from this tube's
    /// hit at `p`: the computed wall distance is at least the distance to the
    /// whole centreline minus the largest radius, that distance is
    /// 1-Lipschitz, and chunks whose box misses `p` are farther than their
    /// radius plus `cull` (a miss: every chunk).
    fn sdf_floor(&self, hit: &Hit) -> f64 {
        hit.dist.min(self.rmin + self.cull) - self.rmax
    }

    /// Closest centreline point among the chunks whose box holds `p`.
    pub(super) fn hit(&self, p: V3) -> Hit {
        let mut best = (f64::INFINITY, 0usize, 0.0f64);
        for c in &self.chunks {
            if (0..3).any(|k| p[k] < c.lo[k] || p[k] > c.hi[k]) {
                continue;
            }
            for s in c.first_seg..c.end_seg {
                let a = self.pts[s];
                let (ab, ab2) = self.segs[s];
                let u = (dot(sub(p, a), ab) / ab2).clamp(0.0, 1.0);
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
    pub(super) fn integrate_pressure(&mut self, p0: f64) {
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
    pub(super) fn pressure_at_arc(&self, s: f64) -> f64 {
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
pub(super) struct Geometry {
    pub(super) tubes: [Tube; 4],
}

/// Parent-curve parameter where the side branch leaves.
pub(super) const SIDE_T: f64 = 0.45;

impl Geometry {
    /// `cull`: tubes farther than this (plus their radius) from a point are
    /// not evaluated there; the signed distance is then only known to be
    /// larger than `cull - K_JUNCTION / 4`-ish, which is all the mesher needs.
    pub(super) fn new(cull: f64) -> Geometry {
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

    pub(super) fn hits(&self, p: V3) -> [Hit; 4] {
        [
            self.tubes[0].hit(p),
            self.tubes[1].hit(p),
            self.tubes[2].hit(p),
            self.tubes[3].hit(p),
        ]
    }

    pub(super) fn phi_of(h: &[Hit; 4]) -> f64 {
        Self::merge([h[0].sdf, h[1].sdf, h[2].sdf, h[3].sdf])
    }

    /// The smooth union of the four tubes' signed distances.
    pub(super) fn merge(d: [f64; 4]) -> f64 {
        let trunk = smin(d[PARENT], d[SIDE], K_SIDE);
        let crown = smin(d[DAUGHTER_A], d[DAUGHTER_B], K_CARINA);
        smin(trunk, crown, K_JUNCTION)
    }

    /// How far from `p`, whose hits are `h`, every point is certainly
    /// outside (`phi > 0`); 0 when that is not known. Each tube's signed
    /// distance is at least [`Tube::sdf_floor`] less the distance moved, and
    /// each smooth minimum takes at most `k / 4` off the smaller of its two
    /// values; `1e-6` mm covers rounding.
    pub(super) fn clearance(&self, h: &[Hit; 4]) -> f64 {
        let floor = self
            .tubes
            .iter()
            .zip(h)
            .map(|(t, x)| t.sdf_floor(x))
            .fold(f64::INFINITY, f64::min);
        (floor - (K_SIDE.max(K_CARINA) + K_JUNCTION) / 4.0 - 1e-6).max(0.0)
    }

    /// Signed distance (negative inside).
    pub(super) fn phi(&self, p: V3) -> f64 {
        Self::phi_of(&self.hits(p))
    }

    /// Closest point on the surface, by two Newton steps with a
    /// forward-difference gradient.
    pub(super) fn project(&self, mut p: V3, h: f64) -> V3 {
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
    pub(super) fn flow_at(&self, p: V3, d_min: f64) -> (V3, f64, f64) {
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
    pub(super) fn bounds(&self) -> (V3, V3) {
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
    pub(super) fn volume_estimate(&self) -> f64 {
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
