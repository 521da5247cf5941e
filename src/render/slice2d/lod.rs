//! Per-slice level of detail (`slice-lod-memory.txt`, eq. 3) and the
//! paper's Table 2.
//!
//! A slice `x` at distance `d_x` from the eye projects onto the projection
//! plane `w` (at distance `D`) shrunk by `D / d_x`, so a resolution of
//! `R_org · D / d_x` loses nothing the image can show; rounded down to a
//! power of two (without losing texels that were referenced):
//!
//! ```text
//!   R_x = R_org / 2^floor(log2(d_x / D))        (level L_x = floor(log2(d_x / D)), >= 0)
//! ```
//!
//! Level `L` is built from level `L - 1` by 2 x 2 box averaging.

/// The level of a slice at distance `d` for projection-plane distance `big_d`
/// (`floor(log2(d / D))`, at least 0, at most `max_level`). Computed by
/// doubling, so that a ratio of exactly `2^L` gives `L` with no `log2`
/// rounding.
pub fn level(d: f64, big_d: f64, max_level: u32) -> u32 {
    let mut l = 0;
    let mut edge = 2.0 * big_d;
    while l < max_level && d >= edge {
        l += 1;
        edge *= 2.0;
    }
    l
}

/// One row of Table 2.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TableRow {
    /// Distance from the eye to the projection plane (= nearest slice).
    pub d: f64,
    /// MiB of texture with LOD (U1).
    pub u1_mib: u64,
    /// MiB without (U2).
    pub u2_mib: u64,
    /// Reduction `100 (1 - U1 / U2)`, percent.
    pub sigma_percent: f64,
}

/// The paper's Table 2: a `n^3` volume over `(-1,-1,-1)..(1,1,1)`, `n`
/// slices of `n x n` texels of `bytes` each; the nearest slice lies on the
/// projection plane at distance `D` from the eye, slice `x` at
/// `d_x = D + x · 2 / n` (slices `2 / n` apart across the volume's depth of
/// 2). Pure arithmetic: nothing of size `n^3` is allocated.
pub fn table2(n: u64, bytes: u64, distances: &[f64]) -> Vec<TableRow> {
    let max_level = 63 - n.leading_zeros();
    let u2 = n * n * n * bytes;
    distances
        .iter()
        .map(|&big_d| {
            let u1: u64 = (0..n)
                .map(|x| {
                    let d = big_d + x as f64 * 2.0 / n as f64;
                    let side = (n >> level(d, big_d, max_level)).max(1);
                    side * side * bytes
                })
                .sum();
            TableRow {
                d: big_d,
                u1_mib: u1 >> 20,
                u2_mib: u2 >> 20,
                sigma_percent: 100.0 * (1.0 - u1 as f64 / u2 as f64),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table2_is_the_papers() {
        let t = table2(1024, 4, &[0.5, 0.75, 1.0, 1.25, 1.5]);
        let u1: Vec<u64> = t.iter().map(|r| r.u1_mib).collect();
        assert_eq!(u1, vec![1600, 2176, 2560, 2944, 3328]);
        assert!(t.iter().all(|r| r.u2_mib == 4096));
        // The paper prints sigma as whole percent: 61, 47, 37, 28, 19 (37.5
        // printed as 37: rounded half to even, or truncated).
        let s: Vec<f64> = t.iter().map(|r| r.sigma_percent).collect();
        assert_eq!(s, vec![60.9375, 46.875, 37.5, 28.125, 18.75]);
    }

    #[test]
    fn levels_double_with_distance() {
        assert_eq!(level(0.9, 1.0, 10), 0);
        assert_eq!(level(2.0, 1.0, 10), 1);
        assert_eq!(level(3.99, 1.0, 10), 1);
        assert_eq!(level(4.0, 1.0, 10), 2);
        assert_eq!(level(1e9, 1.0, 3), 3);
    }
}
