//! Adaptive emission–absorption quadrature along one straight stretch on
//! which the scalar is linear.
//!
//! # The integral of one piece
//!
//! On a piece of length `h` the scalar runs linearly from `s_a` to `s_b`, and
//! no transfer-function kink lies strictly inside (the caller splits there).
//! With `x ∈ [-1, 1]`, `t(x) = h (x + 1) / 2`, the piece's own colour and
//! transmittance are
//!
//! ```text
//!   D(x) = h/2 ∫_{-1}^{x} tau(s(y)) dy                 (optical depth from the piece's start)
//!   C    = h/2 ∫_{-1}^{1} c(s(x)) tau(s(x)) exp(-D(x)) dx
//!   T    = exp(-D(1))
//! ```
//!
//! # The rule (Gauss–Legendre collocation, order 2m)
//!
//! `tau` and `c` are sampled at the `m = 8` Gauss–Legendre nodes `x_k` (the
//! colour and opacity are linear in `x` on a kink-free piece, so they are
//! interpolated from the piece's ends; `tau` is not linear and is evaluated). The
//! outer integral is the Gauss rule `Σ w_k (...)`. The inner optical depth at
//! each node is the exact integral of the degree-7 polynomial interpolating
//! `tau` at the nodes: `D(x_k) ≈ h/2 Σ_j S_kj tau_j` with the spectral
//! integration matrix `S_kj = ∫_{-1}^{x_k} l_j(y) dy` (`l_j` the Lagrange
//! basis of the nodes). This is the Gauss collocation (implicit Runge–Kutta)
//! scheme for `dT/dt = -tau T, dC/dt = c tau T`; it costs 8 logarithms and 9
//! exponentials per interval and no nested quadrature.
//!
//! # Error control
//!
//! `R[a, b]` is the rule on the whole interval, `R[a, m] ∘ R[m, b]` the two
//! halves composited (`C = C_l + T_l C_r`, `T = T_l T_r`). Their difference
//! (largest of the three colour channels and `T`) estimates the error of the
//! coarse result; the finer one is kept when
//!
//! ```text
//!   |R[a,b] - R[a,m] ∘ R[m,b]| <= tol · h / (L_ref · T_front)
//! ```
//!
//! and otherwise each half is refined the same way (depth limit 30, counted).
//! `T_front` is the transmittance in front of the interval: an error `e` in
//! the interval's `(C, T)` changes the pixel by at most `T_front · e` (the
//! colour behind plus the background it lets through is at most 1, because
//! colours and background are in `[0, 1]`). `L_ref` is the diagonal of the
//! mesh's bounding box, which bounds the total length of any straight ray
//! inside the mesh, so the per-pixel error sums to at most `tol`
//! (as far as the halving estimate is an upper bound, which for these smooth
//! integrands — analytic between kinks — it is by a wide margin: the kept
//! result is the finer one, whose error is typically `2^-16` of the estimate).

use crate::render::gauss::{rule, M};

use crate::scene::transfer::OPACITY_MAX;
use crate::scene::TransferFunction;

/// Deepest interval halving.
const MAX_DEPTH: u32 = 30;

/// Colour and transmittance of a stretch, or of everything in front.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Accum {
    /// Premultiplied colour.
    pub c: [f64; 3],
    /// Transmittance.
    pub t: f64,
}

impl Accum {
    /// Nothing: no colour, full transmittance.
    pub(crate) const CLEAR: Accum = Accum {
        c: [0.0; 3],
        t: 1.0,
    };

    /// `self` in front of `back`.
    fn over(self, back: Accum) -> Accum {
        Accum {
            c: [
                self.c[0] + self.t * back.c[0],
                self.c[1] + self.t * back.c[1],
                self.c[2] + self.t * back.c[2],
            ],
            t: self.t * back.t,
        }
    }

    fn diff(self, o: Accum) -> f64 {
        (self.c[0] - o.c[0])
            .abs()
            .max((self.c[1] - o.c[1]).abs())
            .max((self.c[2] - o.c[2]).abs())
            .max((self.t - o.t).abs())
    }
}

/// Colour and (unclamped) opacity of the transfer function at one scalar.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sample {
    c: [f64; 3],
    o: f64,
}

impl Sample {
    fn lerp(self, b: Sample, w: f64) -> Sample {
        let l = |x: f64, y: f64| x + (y - x) * w;
        Sample {
            c: [
                l(self.c[0], b.c[0]),
                l(self.c[1], b.c[1]),
                l(self.c[2], b.c[2]),
            ],
            o: l(self.o, b.o),
        }
    }
}

/// Quadrature counters.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct QuadCounters {
    /// Kink-free pieces integrated.
    pub pieces: u64,
    /// Rule applications (8 nodes each).
    pub rules: u64,
    /// Intervals accepted at the depth limit without meeting the tolerance.
    pub depth_limited: u64,
}

/// Integrates stretches front to back.
#[derive(Debug, Clone)]
pub(crate) struct Integrator<'a> {
    tf: &'a TransferFunction,
    /// Scalars where the transfer function (or the opacity clamp) has a kink, ascending.
    kinks: Vec<f64>,
    /// Allowed error per unit length at full transmittance: `tol / L_ref`.
    tol_density: f64,
}

impl<'a> Integrator<'a> {
    /// `tol` is the per-pixel absolute error budget, `l_ref` an upper bound of
    /// the length of any ray inside the mesh.
    pub(crate) fn new(tf: &'a TransferFunction, tol: f64, l_ref: f64) -> Integrator<'a> {
        let mut kinks: Vec<f64> = tf.points.iter().map(|p| p.s).collect();
        // Where a linear opacity piece crosses the clamp OPACITY_MAX, the
        // extinction has a kink too.
        for w in tf.points.windows(2) {
            let (a, b) = (w[0], w[1]);
            if b.s > a.s && (a.opacity - OPACITY_MAX) * (b.opacity - OPACITY_MAX) < 0.0 {
                kinks.push(a.s + (OPACITY_MAX - a.opacity) / (b.opacity - a.opacity) * (b.s - a.s));
            }
        }
        kinks.retain(|k| k.is_finite());
        kinks.sort_by(f64::total_cmp);
        kinks.dedup();
        let l_ref = if l_ref > 0.0 && l_ref.is_finite() {
            l_ref
        } else {
            1.0
        };
        Integrator {
            tf,
            kinks,
            tol_density: tol / l_ref,
        }
    }

    /// Composites the stretch `[t0, t1]` (scalar linear from `s0` to `s1`)
    /// behind `acc`.
    pub(crate) fn stretch(
        &self,
        acc: &mut Accum,
        t0: f64,
        t1: f64,
        s0: f64,
        s1: f64,
        ctr: &mut QuadCounters,
    ) {
        let h = t1 - t0;
        if h.is_nan() || h <= 0.0 || h.is_infinite() {
            return;
        }
        let (s0, s1) = (
            if s0.is_finite() { s0 } else { 0.0 },
            if s1.is_finite() { s1 } else { 0.0 },
        );
        let ds = s1 - s0;
        let (mut u_prev, mut s_prev) = (0.0, s0);
        let mut piece = |acc: &mut Accum, u: f64, s: f64| {
            let len = (u - u_prev) * h;
            if len > 0.0 && acc.t >= super::T_MIN {
                ctr.pieces += 1;
                let (a, b) = (self.sample(s_prev), self.sample(s));
                let whole = self.rule(len, a, b, ctr);
                let got = self.adapt(len, a, b, whole, acc.t, 0, ctr);
                *acc = acc.over(got);
            }
            u_prev = u;
            s_prev = s;
        };
        if ds > 0.0 {
            for &k in self.kinks.iter().filter(|&&k| k > s0 && k < s1) {
                piece(acc, (k - s0) / ds, k);
            }
        } else if ds < 0.0 {
            for &k in self.kinks.iter().rev().filter(|&&k| k > s1 && k < s0) {
                piece(acc, (k - s0) / ds, k);
            }
        }
        piece(acc, 1.0, s1);
    }

    #[allow(clippy::too_many_arguments)]
    fn adapt(
        &self,
        h: f64,
        sa: Sample,
        sb: Sample,
        whole: Accum,
        t_front: f64,
        depth: u32,
        ctr: &mut QuadCounters,
    ) -> Accum {
        let sm = sa.lerp(sb, 0.5);
        let l = self.rule(0.5 * h, sa, sm, ctr);
        let r = self.rule(0.5 * h, sm, sb, ctr);
        let split = l.over(r);
        let err = whole.diff(split);
        let tol = self.tol_density * h / t_front.max(1e-300);
        if err <= tol {
            return split;
        }
        if depth >= MAX_DEPTH || !err.is_finite() {
            ctr.depth_limited += 1;
            return split;
        }
        let l = self.adapt(0.5 * h, sa, sm, l, t_front, depth + 1, ctr);
        let r = self.adapt(0.5 * h, sm, sb, r, t_front * l.t, depth + 1, ctr);
        l.over(r)
    }

    /// Colour and opacity at `s`.
    fn sample(&self, s: f64) -> Sample {
        let (c, o) = self.tf.eval(s);
        Sample { c, o }
    }

    /// The collocation rule on one interval of length `h`, with colour and
    /// opacity `a` at its start and `b` at its end. No kink lies inside, so
    /// both are linear in between: interpolating them is the transfer
    /// function itself (and saves its look-up).
    fn rule(&self, h: f64, a: Sample, b: Sample, ctr: &mut QuadCounters) -> Accum {
        ctr.rules += 1;
        let r = rule();
        let mut tau = [0.0; M];
        let mut rgb = [[0.0; 3]; M];
        for k in 0..M {
            let q = a.lerp(b, 0.5 * (r.x[k] + 1.0));
            tau[k] = -(1.0 - q.o.clamp(0.0, OPACITY_MAX)).ln() / self.tf.unit_distance;
            rgb[k] = q.c;
        }
        let hh = 0.5 * h;
        let mut c = [0.0; 3];
        let mut depth = 0.0;
        for k in 0..M {
            let dk: f64 = hh * (0..M).map(|j| r.s[k][j] * tau[j]).sum::<f64>();
            let wt = hh * r.w[k] * tau[k] * (-dk).exp();
            for ch in 0..3 {
                c[ch] += wt * rgb[k][ch];
            }
            depth += hh * r.w[k] * tau[k];
        }
        Accum {
            c,
            t: (-depth).exp(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tf(points: &[[f64; 5]], ud: f64) -> TransferFunction {
        TransferFunction::from_rows(points, ud)
    }

    #[test]
    fn rule_nodes_weights_and_matrix() {
        let r = rule();
        assert!((r.w.iter().sum::<f64>() - 2.0).abs() < 1e-14);
        // Exact for x^15 (odd: 0) and x^14.
        let i14: f64 = (0..M).map(|k| r.w[k] * r.x[k].powi(14)).sum();
        assert!((i14 - 2.0 / 15.0).abs() < 1e-14);
        // S integrates x^3 exactly: ∫_{-1}^{x_k} y^3 = (x_k^4 - 1) / 4.
        for k in 0..M {
            let v: f64 = (0..M).map(|j| r.s[k][j] * r.x[j].powi(3)).sum();
            assert!((v - (r.x[k].powi(4) - 1.0) / 4.0).abs() < 1e-14);
        }
    }

    #[test]
    fn constant_field_is_closed_form() {
        let t = tf(&[[0.0, 0.2, 0.4, 0.6, 0.3], [1.0, 0.2, 0.4, 0.6, 0.3]], 2.0);
        let q = Integrator::new(&t, 1e-9, 10.0);
        let mut acc = Accum::CLEAR;
        let mut ctr = QuadCounters::default();
        q.stretch(&mut acc, 1.0, 8.0, 0.5, 0.5, &mut ctr);
        let alpha = 1.0 - 0.7f64.powf(7.0 / 2.0);
        assert!((acc.t - (1.0 - alpha)).abs() < 1e-13);
        for (ch, c) in [0.2, 0.4, 0.6].iter().enumerate() {
            assert!((acc.c[ch] - c * alpha).abs() < 1e-10, "{:?}", acc);
        }
    }

    #[test]
    fn clamp_kink_is_a_breakpoint() {
        let t = tf(&[[0.0, 1.0, 1.0, 1.0, 0.5], [1.0, 1.0, 1.0, 1.0, 1.0]], 1.0);
        let q = Integrator::new(&t, 1e-6, 1.0);
        assert_eq!(q.kinks.len(), 3);
        assert!((q.kinks[1] - (1.0 - 2e-6)).abs() < 1e-12);
    }
}
