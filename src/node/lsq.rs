//! Small non-negative least squares for fitting unit costs: minimise
//! `sum_i w_i (y_i - x_i · c)^2` over `c >= 0`.
//!
//! Solved by the normal equations (a few unknowns, Gaussian elimination
//! with partial pivoting, in f64, columns scaled to unit norm first) inside a
//! simple active-set loop: when a coefficient comes out negative, the most
//! negative one is fixed at 0 and the rest refitted. Good enough for a
//! handful of well-separated operation kinds; reports R² and residuals.

/// The result of a fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// Coefficients, one per column (0 for columns dropped by the constraint).
    pub coef: Vec<f64>,
    /// Coefficient of determination of the weighted fit (`1 - SS_res / SS_tot`).
    pub r2: f64,
    /// Per sample, `y - prediction`.
    pub residuals: Vec<f64>,
}

/// Solves `a x = b` (n x n, row-major) by elimination; `None` if singular.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for k in 0..n {
        let p = (k..n).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if a[p][k].abs() < 1e-300 {
            return None;
        }
        a.swap(k, p);
        b.swap(k, p);
        let (top, rest) = a.split_at_mut(k + 1);
        let pivot = &top[k];
        for (off, row) in rest.iter_mut().enumerate() {
            let f = row[k] / pivot[k];
            for (x, p) in row[k..].iter_mut().zip(&pivot[k..]) {
                *x -= f * p;
            }
            b[k + 1 + off] -= f * b[k];
        }
    }
    let mut x = vec![0.0; n];
    for k in (0..n).rev() {
        let s: f64 = (k + 1..n).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - s) / a[k][k];
    }
    Some(x)
}

/// Non-negative weighted least squares of `y` on the rows `x` (see the module docs).
pub fn nnls(x: &[Vec<f64>], y: &[f64], w: &[f64]) -> Fit {
    let m = x.first().map_or(0, |r| r.len());
    let mut active: Vec<bool> = (0..m).map(|j| x.iter().any(|r| r[j] != 0.0)).collect();
    let mut coef = vec![0.0; m];
    loop {
        let cols: Vec<usize> = (0..m).filter(|&j| active[j]).collect();
        if cols.is_empty() {
            break;
        }
        let norm: Vec<f64> = cols
            .iter()
            .map(|&j| {
                x.iter()
                    .zip(w)
                    .map(|(r, wi)| wi * r[j] * r[j])
                    .sum::<f64>()
                    .sqrt()
                    .max(1e-300)
            })
            .collect();
        let k = cols.len();
        let mut ata = vec![vec![0.0; k]; k];
        let mut aty = vec![0.0; k];
        for (r, (&yi, &wi)) in x.iter().zip(y.iter().zip(w)) {
            for a in 0..k {
                let va = r[cols[a]] / norm[a];
                aty[a] += wi * va * yi;
                for b in 0..k {
                    ata[a][b] += wi * va * r[cols[b]] / norm[b];
                }
            }
        }
        let Some(sol) = solve(ata, aty) else {
            // Singular: drop the last active column and retry.
            active[*cols.last().expect("non-empty")] = false;
            continue;
        };
        let sol: Vec<f64> = sol.iter().zip(&norm).map(|(s, n)| s / n).collect();
        let worst = (0..k)
            .filter(|&a| sol[a] < 0.0)
            .min_by(|&a, &b| sol[a].total_cmp(&sol[b]));
        match worst {
            Some(a) => active[cols[a]] = false,
            None => {
                coef = vec![0.0; m];
                for (a, &j) in cols.iter().enumerate() {
                    coef[j] = sol[a];
                }
                break;
            }
        }
    }
    let pred: Vec<f64> = x
        .iter()
        .map(|r| r.iter().zip(&coef).map(|(a, c)| a * c).sum())
        .collect();
    let residuals: Vec<f64> = y.iter().zip(&pred).map(|(a, p)| a - p).collect();
    let wsum: f64 = w.iter().sum::<f64>().max(1e-300);
    let mean = y.iter().zip(w).map(|(a, wi)| a * wi).sum::<f64>() / wsum;
    let ss_tot: f64 = y.iter().zip(w).map(|(a, wi)| wi * (a - mean).powi(2)).sum();
    let ss_res: f64 = residuals.iter().zip(w).map(|(r, wi)| wi * r * r).sum();
    Fit {
        coef,
        r2: if ss_tot > 0.0 {
            1.0 - ss_res / ss_tot
        } else {
            1.0
        },
        residuals,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_exact_coefficients_and_clamps_negative_ones() {
        let x: Vec<Vec<f64>> = (0..20)
            .map(|i| vec![i as f64, (i * i % 7) as f64, 1.0])
            .collect();
        let y: Vec<f64> = x.iter().map(|r| 2e-6 * r[0] + 5e-7 * r[1] + 1e-5).collect();
        let f = nnls(&x, &y, &[1.0; 20]);
        assert!((f.coef[0] - 2e-6).abs() < 1e-15 && (f.coef[1] - 5e-7).abs() < 1e-15);
        assert!(f.r2 > 0.999999);
        let y2: Vec<f64> = x.iter().map(|r| 2e-6 * r[0] - 5e-7 * r[1]).collect();
        let f2 = nnls(&x, &y2, &[1.0; 20]);
        assert!(f2.coef.iter().all(|&c| c >= 0.0));
        assert_eq!(f2.coef[1], 0.0);
    }
}
