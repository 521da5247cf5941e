//! One axis of a block: which samples a block holds, where its reduced
//! samples sit, and the weights that rebuild an original sample from them.
//!
//! A block holds `m` consecutive original samples along an axis (local
//! positions `x = 0 .. m-1`). At level `l` it keeps `n_l = ceil(m / 2^l)`
//! samples; reduced sample `k` is the mean of the original samples
//! `[k 2^l, min((k+1) 2^l, m))` (the paper's 2x2x2 averaging, applied `l`
//! times; the last one may cover fewer when `m` is not a multiple of `2^l`)
//! and sits at their mean position
//!
//! ```text
//!   p_k = (k 2^l + min((k+1) 2^l, m) - 1) / 2 .
//! ```
//!
//! The block's field at original position `x` is the linear interpolation
//! of the reduced samples at the `p_k`, and the linear *extrapolation* of
//! the outermost two beyond `p_0` and `p_{n-1}` (up to the block's own
//! outermost samples: less than one reduced spacing):
//!
//! ```text
//!   ṽ(x) = (1 - w) R[k0] + w R[k1],  w = (x - p_k0) / (p_k1 - p_k0),  k1 = k0 + 1
//! ```
//!
//! with `w` in `[0, 1]` inside and slightly outside `[0, 1]` at the ends.
//! Clamping to the edge instead (a texture's `GL_CLAMP_TO_EDGE`) is what a
//! GPU would do, but it makes the error of a smooth field grow towards
//! every block face (a ramp loses `slope x (2^l - 1) / 2` at the outermost
//! samples), which draws the block grid into the image; extrapolation keeps
//! linear fields exact up to the faces. An axis with one reduced sample is
//! constant. The error the builder checks includes the ends, so the
//! tolerance bounds the extrapolation too.
//!
//! In 3D the weights of the three axes multiply (trilinear). At level 0,
//! `p_k = k` and `ṽ = v` exactly.

/// Reconstruction weights of one axis of a block at one level.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisLevel {
    /// Reduced samples along the axis, `n_l = ceil(m / 2^l)`.
    pub n: usize,
    /// Per local original position `x`: `(k0, k1, w)` with
    /// `ṽ(x) = (1 - w) R[k0] + w R[k1]` (`k1 = k0 + 1`, or `k1 = k0`
    /// with `w = 0` on a sample and when `n = 1`).
    pub weights: Vec<(u32, u32, f32)>,
}

impl AxisLevel {
    /// The weights for `m` original samples at level `l`.
    pub fn new(m: usize, l: u32) -> AxisLevel {
        assert!(m >= 1, "a block holds at least one sample per axis");
        let step = 1usize << l;
        let n = m.div_ceil(step);
        let p: Vec<f64> = (0..n)
            .map(|k| (k * step + (((k + 1) * step).min(m)) - 1) as f64 / 2.0)
            .collect();
        let mut weights = Vec::with_capacity(m);
        let mut k = 0usize;
        for x in 0..m {
            let xf = x as f64;
            while k + 2 < n && p[k + 1] <= xf {
                k += 1;
            }
            // k: the interval [p_k, p_k+1] holding x, or the outermost one.
            let w = if n == 1 || xf == p[k] {
                (k as u32, k as u32, 0.0)
            } else if xf == p[k + 1] {
                (k as u32 + 1, k as u32 + 1, 0.0)
            } else {
                let t = (xf - p[k]) / (p[k + 1] - p[k]);
                (k as u32, k as u32 + 1, t as f32)
            };
            weights.push(w);
        }
        AxisLevel { n, weights }
    }

    /// Reduced sample ranges `[k 2^l, min((k+1) 2^l, m))` of level `l`.
    pub fn cover(m: usize, l: u32, k: usize) -> std::ops::Range<usize> {
        let step = 1usize << l;
        k * step..((k + 1) * step).min(m)
    }
}

/// Highest level at which an axis of `m` samples still changes
/// (`ceil(m / 2^l) > 1` for `l` below it).
pub fn max_level(m: usize) -> u32 {
    let mut l = 0;
    while m.div_ceil(1 << l) > 1 {
        l += 1;
    }
    l
}

/// Splits `n` samples into `b` near-equal parts: part `i` is
/// `[floor(i n / b), floor((i+1) n / b))`; `b` is capped at `n`.
pub fn split(n: u64, b: u64) -> Vec<u64> {
    let b = b.clamp(1, n.max(1));
    (0..=b).map(|i| i * n / b).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn level_zero_is_the_identity() {
        let a = AxisLevel::new(7, 0);
        assert_eq!(a.n, 7);
        for (x, &(k0, k1, w)) in a.weights.iter().enumerate() {
            assert_eq!((k0 as usize, k1 as usize, w), (x, x, 0.0));
        }
    }

    #[test]
    fn level_one_of_eight() {
        // Centres at 0.5, 2.5, 4.5, 6.5.
        let a = AxisLevel::new(8, 1);
        assert_eq!(a.n, 4);
        assert_eq!(a.weights[0], (0, 1, -0.25));
        assert_eq!(a.weights[1], (0, 1, 0.25));
        assert_eq!(a.weights[2], (0, 1, 0.75));
        assert_eq!(a.weights[3], (1, 2, 0.25));
        assert_eq!(a.weights[7], (2, 3, 1.25));
    }

    proptest! {
        /// Every level reproduces a linear function exactly (up to the
        /// block's ends), with at most half a reduced spacing of
        /// extrapolation (up to a whole one next to a short last sample).
        #[test]
        fn linear_fields_are_kept(m in 1usize..70, l in 0u32..7) {
            let a = AxisLevel::new(m, l);
            prop_assert_eq!(a.n, m.div_ceil(1 << l));
            // Reduced samples of f(x) = x are the mean positions.
            let r: Vec<f64> = (0..a.n).map(|k| {
                let c = AxisLevel::cover(m, l, k);
                c.clone().map(|x| x as f64).sum::<f64>() / c.len() as f64
            }).collect();
            for (x, &(k0, k1, w)) in a.weights.iter().enumerate() {
                prop_assert!((-1.0..=2.0).contains(&w), "w {}", w);
                prop_assert!((k0 as usize) < a.n && (k1 as usize) < a.n && k1 >= k0 && k1 <= k0 + 1);
                let v = (1.0 - w as f64) * r[k0 as usize] + w as f64 * r[k1 as usize];
                let want = if a.n == 1 { r[0] } else { x as f64 };
                prop_assert!((v - want).abs() < 1e-5, "x {} v {} want {}", x, v, want);
            }
        }

        #[test]
        fn split_covers(n in 1u64..2000, b in 1u64..40) {
            let s = split(n, b);
            prop_assert_eq!(s[0], 0);
            prop_assert_eq!(*s.last().unwrap(), n);
            prop_assert!(s.windows(2).all(|w| w[1] > w[0]));
        }
    }
}
