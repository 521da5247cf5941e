//! The 8-node Gauss–Legendre collocation rule both f64 oracles integrate
//! with (the mesh reference [`super::reference`] and the grid reference
//! [`super::grid_reference`]); each oracle keeps its own integrand, error
//! control and walk, and only this table of numbers is shared.
//!
//! On `[-1, 1]`:
//!
//! - nodes `x_k`: the roots of the Legendre polynomial `P_M`, ascending,
//!   found by Newton's method on the three-term recurrence;
//! - weights `w_k = 2 / ((1 - x_k²) P_M'(x_k)²)`; the rule is exact for
//!   polynomials of degree `2M - 1 = 15`;
//! - the spectral integration matrix `S_kj = ∫_{-1}^{x_k} l_j(y) dy`, `l_j`
//!   the Lagrange basis of the nodes, so that `Σ_j S_kj f(x_j)` is the exact
//!   integral from -1 to `x_k` of the degree-7 interpolant of `f`. It is
//!   computed by expanding `l_j` in monomials and integrating exactly; the
//!   tests check it against the Gauss rule applied on `[-1, x_k]` (exact for
//!   the degree-7 `l_j`), a computation that shares no step with it.

use std::sync::OnceLock;

/// Nodes of the rule.
pub const M: usize = 8;

/// Nodes, weights and spectral integration matrix.
#[derive(Debug)]
pub struct Rule {
    /// Nodes `x_k`, ascending, in `(-1, 1)`.
    pub x: [f64; M],
    /// Weights `w_k`.
    pub w: [f64; M],
    /// `s[k][j] = ∫_{-1}^{x_k} l_j`.
    pub s: [[f64; M]; M],
}

/// `P_n(x)` and `P_n'(x)` by the three-term recurrence.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
}

/// Nodes and weights.
fn nodes() -> ([f64; M], [f64; M]) {
    let mut x = [0.0; M];
    let mut w = [0.0; M];
    for (k, (xk, wk)) in x.iter_mut().zip(w.iter_mut()).enumerate() {
        // Newton from the Chebyshev-like guess; nodes ascending.
        let mut r = -(std::f64::consts::PI * (k as f64 + 0.75) / (M as f64 + 0.5)).cos();
        for _ in 0..100 {
            let (p, dp) = legendre(M, r);
            let dr = p / dp;
            r -= dr;
            if dr.abs() < 1e-16 {
                break;
            }
        }
        let (_, dp) = legendre(M, r);
        *xk = r;
        *wk = 2.0 / ((1.0 - r * r) * dp * dp);
    }
    (x, w)
}

/// `S_kj` by exact integration of `l_j` expanded in monomials.
fn spectral(x: &[f64; M]) -> [[f64; M]; M] {
    let mut s = [[0.0; M]; M];
    for j in 0..M {
        let mut coef = vec![1.0f64]; // ascending powers
        let mut denom = 1.0;
        for (i, &xi) in x.iter().enumerate() {
            if i == j {
                continue;
            }
            // multiply by (y - x_i)
            let mut next = vec![0.0; coef.len() + 1];
            for (p, &c) in coef.iter().enumerate() {
                next[p + 1] += c;
                next[p] -= c * xi;
            }
            coef = next;
            denom *= x[j] - xi;
        }
        let prim = |y: f64| {
            coef.iter()
                .enumerate()
                .rev()
                .fold(0.0, |acc, (p, &c)| acc * y + c / (p + 1) as f64)
                * y
        };
        for k in 0..M {
            s[k][j] = (prim(x[k]) - prim(-1.0)) / denom;
        }
    }
    s
}

/// The rule, computed once.
pub fn rule() -> &'static Rule {
    static R: OnceLock<Rule> = OnceLock::new();
    R.get_or_init(|| {
        let (x, w) = nodes();
        let s = spectral(&x);
        Rule { x, w, s }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_for_degree_15() {
        let r = rule();
        for deg in 0..=15u32 {
            let got: f64 = (0..M).map(|k| r.w[k] * r.x[k].powi(deg as i32)).sum();
            let want = if deg % 2 == 1 {
                0.0
            } else {
                2.0 / (deg + 1) as f64
            };
            assert!((got - want).abs() < 1e-14, "degree {deg}: {got} vs {want}");
        }
        assert!(r.x.windows(2).all(|p| p[0] < p[1]));
    }

    /// `S` against the Gauss rule on `[-1, x_k]` (exact: `l_j` has degree 7).
    #[test]
    fn spectral_matrix_agrees_with_gauss_on_subintervals() {
        let r = rule();
        let lagrange = |j: usize, y: f64| -> f64 {
            (0..M)
                .filter(|&i| i != j)
                .map(|i| (y - r.x[i]) / (r.x[j] - r.x[i]))
                .product()
        };
        for k in 0..M {
            let half = 0.5 * (r.x[k] + 1.0);
            for j in 0..M {
                let g: f64 = (0..M)
                    .map(|q| r.w[q] * half * lagrange(j, -1.0 + half * (r.x[q] + 1.0)))
                    .sum();
                assert!((g - r.s[k][j]).abs() < 1e-13, "S[{k}][{j}]");
            }
        }
        // Integrating 1 from -1 to x_k gives x_k + 1.
        for k in 0..M {
            let sum: f64 = r.s[k].iter().sum();
            assert!((sum - (r.x[k] + 1.0)).abs() < 1e-14);
        }
    }
}
