//! The trilinear field along a straight ray inside one voxel cell is a cubic
//! in the ray parameter, and where it crosses the transfer function's kinks.
//!
//! # The cubic
//!
//! In the cell with lower corner `c` (grid coordinates), the local
//! coordinates along the ray are `u(τ) = u0 + du τ`, `v(τ)`, `w(τ)` likewise
//! (τ measured from the cell entry). The trilinear interpolant is
//!
//! ```text
//!   s(τ) = Σ_{i,j,k ∈ {0,1}} s_ijk · L_i(u(τ)) L_j(v(τ)) L_k(w(τ)),
//!   L_0(x) = 1 - x,  L_1(x) = x,
//! ```
//!
//! a product of three linear polynomials per corner: a cubic
//! `s(τ) = p0 + p1 τ + p2 τ² + p3 τ³`, expanded exactly (in f64) below.
//!
//! # Kinks
//!
//! The transfer function is piecewise linear in `s`; its kinks `b` (control
//! points and the opacity clamp) are crossed where `s(τ) = b`. The cubic is
//! cut at its critical points (roots of `s'`, a quadratic) into monotone
//! pieces, and on each monotone piece every `b` strictly between the end
//! values is found by bisection (safe, to 1e-15 of the interval): between
//! consecutive cuts the integrand is then analytic.

/// A cubic `p[0] + p[1] τ + p[2] τ² + p[3] τ³`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cubic(pub [f64; 4]);

impl Cubic {
    /// The value at `t` (Horner).
    #[inline]
    pub fn eval(&self, t: f64) -> f64 {
        let p = &self.0;
        ((p[3] * t + p[2]) * t + p[1]) * t + p[0]
    }

    /// The trilinear field of a cell with corner values `s[k][j][i]`
    /// (i along x) along local coordinates `u0 + du τ` (per axis).
    pub fn trilinear(s: &[[[f64; 2]; 2]; 2], u0: [f64; 3], du: [f64; 3]) -> Cubic {
        // L_0 = (1 - u0) - du τ, L_1 = u0 + du τ, as [const, slope].
        let lin = |a: usize, which: usize| -> [f64; 2] {
            if which == 0 {
                [1.0 - u0[a], -du[a]]
            } else {
                [u0[a], du[a]]
            }
        };
        let mut p = [0.0; 4];
        for (k, plane) in s.iter().enumerate() {
            let lz = lin(2, k);
            for (j, row) in plane.iter().enumerate() {
                let ly = lin(1, j);
                // (ly * lz): quadratic
                let q = [ly[0] * lz[0], ly[0] * lz[1] + ly[1] * lz[0], ly[1] * lz[1]];
                for (i, &v) in row.iter().enumerate() {
                    let lx = lin(0, i);
                    p[0] += v * lx[0] * q[0];
                    p[1] += v * (lx[0] * q[1] + lx[1] * q[0]);
                    p[2] += v * (lx[0] * q[2] + lx[1] * q[1]);
                    p[3] += v * lx[1] * q[2];
                }
            }
        }
        Cubic(p)
    }

    /// The roots of `s'` strictly inside `(0, len)`, ascending.
    fn critical_points(&self, len: f64) -> ([f64; 2], usize) {
        // s' = p1 + 2 p2 τ + 3 p3 τ²
        let (a, b, c) = (3.0 * self.0[3], 2.0 * self.0[2], self.0[1]);
        let mut r = [0.0; 2];
        let mut n = 0;
        let mut push = |t: f64| {
            if t > 0.0 && t < len && t.is_finite() {
                r[n] = t;
                n += 1;
            }
        };
        let scale = a.abs().max(b.abs()).max(c.abs());
        if scale == 0.0 {
            return (r, 0);
        }
        if a.abs() <= 1e-14 * scale {
            if b != 0.0 {
                push(-c / b);
            }
        } else {
            let disc = b * b - 4.0 * a * c;
            if disc > 0.0 {
                // Stable form: q = -(b + sign(b) sqrt(disc)) / 2.
                let q = -0.5 * (b + b.signum() * disc.sqrt());
                let (t1, t2) = if q != 0.0 { (q / a, c / q) } else { (0.0, 0.0) };
                push(t1.min(t2));
                push(t1.max(t2));
            }
        }
        if n == 2 && r[0] > r[1] {
            r.swap(0, 1);
        }
        (r, n)
    }

    /// Every `τ` in `(0, len)` where the cubic crosses one of `levels`,
    /// appended to `out` (unsorted). `levels` need not be sorted.
    pub fn crossings(&self, len: f64, levels: &[f64], out: &mut Vec<f64>) {
        let (cp, n) = self.critical_points(len);
        let mut knots = [0.0; 4];
        knots[1..1 + n].copy_from_slice(&cp[..n]);
        knots[1 + n] = len;
        for w in knots[..n + 2].windows(2) {
            let (a, b) = (w[0], w[1]);
            let (sa, sb) = (self.eval(a), self.eval(b));
            let (lo, hi) = if sa <= sb { (sa, sb) } else { (sb, sa) };
            for &l in levels {
                if l > lo && l < hi {
                    out.push(self.bisect(a, b, sa, l));
                }
            }
        }
    }

    /// The crossing of `level` on the monotone piece `[a, b]` (the level
    /// lies strictly between the end values).
    fn bisect(&self, mut a: f64, mut b: f64, sa: f64, level: f64) -> f64 {
        let below_at_a = sa < level;
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if m <= a || m >= b {
                break;
            }
            if (self.eval(m) < level) == below_at_a {
                a = m;
            } else {
                b = m;
            }
        }
        0.5 * (a + b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[allow(clippy::needless_range_loop)]
    fn direct(s: &[[[f64; 2]; 2]; 2], g: [f64; 3]) -> f64 {
        let mut v = 0.0;
        for k in 0..2 {
            for j in 0..2 {
                for i in 0..2 {
                    let wx = if i == 0 { 1.0 - g[0] } else { g[0] };
                    let wy = if j == 0 { 1.0 - g[1] } else { g[1] };
                    let wz = if k == 0 { 1.0 - g[2] } else { g[2] };
                    v += s[k][j][i] * wx * wy * wz;
                }
            }
        }
        v
    }

    proptest! {
        #[test]
        fn cubic_equals_trilinear(
            vals in proptest::array::uniform8(-10.0f64..10.0),
            u0 in proptest::array::uniform3(0.0f64..1.0),
            du in proptest::array::uniform3(-1.0f64..1.0),
            t in 0.0f64..1.0,
        ) {
            let s = [[[vals[0], vals[1]], [vals[2], vals[3]]], [[vals[4], vals[5]], [vals[6], vals[7]]]];
            let c = Cubic::trilinear(&s, u0, du);
            let g = [u0[0] + du[0] * t, u0[1] + du[1] * t, u0[2] + du[2] * t];
            prop_assert!((c.eval(t) - direct(&s, g)).abs() < 1e-11);
        }

        #[test]
        fn crossings_are_roots_and_complete(
            p in proptest::array::uniform4(-5.0f64..5.0),
            level in -5.0f64..5.0,
        ) {
            let c = Cubic(p);
            let mut out = Vec::new();
            c.crossings(2.0, &[level], &mut out);
            for &t in &out {
                prop_assert!(t > 0.0 && t < 2.0);
                prop_assert!((c.eval(t) - level).abs() < 1e-9);
            }
            // Completeness: every sign change on a fine grid is near a found root.
            let n = 2000;
            for i in 0..n {
                let (a, b) = (2.0 * i as f64 / n as f64, 2.0 * (i + 1) as f64 / n as f64);
                let (fa, fb) = (c.eval(a) - level, c.eval(b) - level);
                if fa * fb < 0.0 {
                    prop_assert!(out.iter().any(|&t| t >= a - 1e-9 && t <= b + 1e-9),
                        "sign change in [{a}, {b}] not found: {out:?}");
                }
            }
        }
    }
}
