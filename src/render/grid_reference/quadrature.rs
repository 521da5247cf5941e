//! Adaptive emission–absorption quadrature along one stretch of a ray on
//! which the transfer function has no kink (the caller splits the stretch
//! at every control point the field crosses).
//!
//! # The integral of one piece
//!
//! On a piece `[a, b]` of length `h`, with `x ∈ [-1, 1]`,
//! `t(x) = a + h (x + 1) / 2`, the piece's own colour and transmittance are
//!
//! ```text
//!   D(x) = h/2 ∫_{-1}^{x} tau(t(y)) dy                 optical depth from a
//!   C    = h/2 ∫_{-1}^{1} c(t(x)) tau(t(x)) exp(-D(x)) dx
//!   T    = exp(-D(1))
//! ```
//!
//! # The rule: Gauss–Legendre collocation of order 2m, m = 8
//!
//! `c` and `tau` are evaluated at the `m` Gauss–Legendre nodes `x_k`; the
//! outer integral is the Gauss rule `Σ w_k c_k tau_k exp(-D_k)` and the inner
//! optical depth at each node is the exact integral of the degree-7
//! polynomial interpolating `tau`, `D_k = h/2 Σ_j S_kj tau_j` with
//! `S_kj = ∫_{-1}^{x_k} l_j(y) dy` (`l_j` the Lagrange basis of the nodes).
//!
//! # Error control
//!
//! `R[a,b]` is compared with its two halves composited
//! (`C = C_l + T_l C_r`, `T = T_l T_r`); the finer result is kept when the
//! largest difference of the three colour channels and `T` is at most
//! `tol · h / (L · T_front)`: an error `e` in the piece's `(C, T)` moves the
//! pixel by at most `T_front · e` (colours and background are in `[0, 1]`),
//! and `L`, the volume box's diagonal, bounds the length of any ray inside
//! the box, so the per-pixel error sums to at most `tol`. Otherwise each half
//! is refined the same way (depth limit [`MAX_DEPTH`], counted).
//!
//! The two oracles share only the rule's table of nodes, weights and `S`
//! ([`crate::render::gauss`], tested on its own); the integrand, the error
//! control and the walk are the grid reference's.

use crate::render::gauss::{rule, M};

/// Deepest interval halving.
pub const MAX_DEPTH: u32 = 40;

/// Premultiplied colour and transmittance of a stretch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    /// Emitted colour reaching the stretch's front, `∫ c tau T`.
    pub c: [f64; 3],
    /// Transmittance of the stretch.
    pub t: f64,
}

impl Piece {
    /// The empty stretch.
    pub const EMPTY: Piece = Piece {
        c: [0.0; 3],
        t: 1.0,
    };

    /// `self` in front of `back`: `C = C_f + T_f C_b`, `T = T_f T_b`.
    #[inline]
    pub fn over(self, back: Piece) -> Piece {
        Piece {
            c: [
                self.c[0] + self.t * back.c[0],
                self.c[1] + self.t * back.c[1],
                self.c[2] + self.t * back.c[2],
            ],
            t: self.t * back.t,
        }
    }
}

/// One application of the rule on `[a, b]`. `field(t)` returns the colour
/// and the extinction `tau` at ray parameter `t`.
fn apply(field: &impl Fn(f64) -> ([f64; 3], f64), a: f64, b: f64) -> Piece {
    let r = rule();
    let half = 0.5 * (b - a);
    let mut c = [[0.0; 3]; M];
    let mut tau = [0.0; M];
    for k in 0..M {
        let (ck, tk) = field(a + half * (r.x[k] + 1.0));
        c[k] = ck;
        tau[k] = tk;
    }
    let mut out = [0.0; 3];
    let mut depth = 0.0;
    for k in 0..M {
        let d: f64 = (0..M).map(|j| r.s[k][j] * tau[j]).sum::<f64>() * half;
        let g = r.w[k] * tau[k] * (-d).exp();
        for ch in 0..3 {
            out[ch] += g * c[k][ch];
        }
        depth += r.w[k] * tau[k];
    }
    Piece {
        c: out.map(|v| v * half),
        t: (-depth * half).exp(),
    }
}

fn diff(p: Piece, q: Piece) -> f64 {
    (0..3)
        .map(|i| (p.c[i] - q.c[i]).abs())
        .fold((p.t - q.t).abs(), f64::max)
}

/// Counters of the adaptive integration.
#[derive(Debug, Default, Clone, Copy)]
pub struct QuadCounters {
    /// Rule applications.
    pub rules: u64,
    /// Intervals accepted at the depth limit without meeting the tolerance.
    pub depth_limited: u64,
}

/// Integrates one kink-free stretch `[a, b]` behind transmittance `t_front`;
/// `density` is `tol / L` (error allowed per unit length).
pub fn integrate(
    field: &impl Fn(f64) -> ([f64; 3], f64),
    a: f64,
    b: f64,
    t_front: f64,
    density: f64,
    n: &mut QuadCounters,
) -> Piece {
    if b <= a {
        return Piece::EMPTY;
    }
    n.rules += 1;
    let whole = apply(field, a, b);
    refine(field, a, b, whole, t_front, density, 0, n)
}

#[allow(clippy::too_many_arguments)]
fn refine(
    field: &impl Fn(f64) -> ([f64; 3], f64),
    a: f64,
    b: f64,
    whole: Piece,
    t_front: f64,
    density: f64,
    depth: u32,
    n: &mut QuadCounters,
) -> Piece {
    let m = 0.5 * (a + b);
    n.rules += 2;
    let l = apply(field, a, m);
    let r = apply(field, m, b);
    let fine = l.over(r);
    if diff(whole, fine) * t_front <= density * (b - a) || t_front < 1e-14 {
        return fine;
    }
    if depth >= MAX_DEPTH {
        n.depth_limited += 1;
        return fine;
    }
    let l = refine(field, a, m, l, t_front, density, depth + 1, n);
    let r = refine(field, m, b, r, t_front * l.t, density, depth + 1, n);
    l.over(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_medium_is_closed_form() {
        // c = 0.7, tau = 0.3 over length 2: C = c (1 - e^{-tau h}), T = e^{-tau h}.
        let f = |_t: f64| ([0.7, 0.7, 0.7], 0.3);
        let mut n = QuadCounters::default();
        let p = integrate(&f, 1.0, 3.0, 1.0, 1e-9, &mut n);
        let t = (-0.6f64).exp();
        assert!((p.t - t).abs() < 1e-14);
        assert!((p.c[0] - 0.7 * (1.0 - t)).abs() < 1e-14);
    }

    #[test]
    fn linear_extinction_matches_its_closed_form() {
        // tau = k t on [0, h]: T = exp(-k h^2 / 2); with c = 1, C = 1 - T.
        let k = 3.0;
        let f = |t: f64| ([1.0, 0.5, 0.0], k * t);
        let mut n = QuadCounters::default();
        let p = integrate(&f, 0.0, 1.5, 1.0, 1e-9, &mut n);
        let t = (-k * 1.5 * 1.5 / 2.0f64).exp();
        assert!((p.t - t).abs() < 1e-12, "{} vs {t}", p.t);
        assert!((p.c[0] - (1.0 - t)).abs() < 1e-12);
        assert!((p.c[1] - 0.5 * (1.0 - t)).abs() < 1e-12);
    }
}
