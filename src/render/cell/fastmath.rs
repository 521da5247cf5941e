//! `ln` and `exp` for the integrator's hot loop, in f32, inlined and
//! branch-light (libm's `logf`/`expf` are calls and `expm1f` is slow).
//! Relative error below 2e-7 over the ranges used (tested against f64).

/// Natural logarithm for normal positive `x` (the integrator calls it with
/// transmittances in `[1e-6, 1]`).
///
/// `x = 2^e m`, `m` folded into `[√½, √2)`; `ln m = 2 artanh(t)` with
/// `t = (m - 1)/(m + 1)`, `|t| <= 0.172`, by its odd series to `t^9`.
#[inline(always)]
pub fn ln(x: f32) -> f32 {
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    // Selects rather than a branch, so that batches vectorise.
    let big = m > std::f32::consts::SQRT_2;
    let m = if big { m * 0.5 } else { m };
    let e = e + big as i32;
    let t = (m - 1.0) / (m + 1.0);
    let t2 = t * t;
    let series = 1.0 + t2 * (1.0 / 3.0 + t2 * (1.0 / 5.0 + t2 * (1.0 / 7.0 + t2 * (1.0 / 9.0))));
    e as f32 * std::f32::consts::LN_2 + 2.0 * t * series
}

/// `e^x` for `x <= 0` (inputs below -87 give ~0).
///
/// `x = k ln2 + r` with `|r| <= ln2/2`; `e^r` by its Taylor polynomial to `r^7`;
/// `2^k` put into the exponent bits.
#[inline(always)]
pub fn exp_neg(x: f32) -> f32 {
    let x = x.max(-87.0);
    // Round to nearest by the 1.5 * 2^23 trick (no libm call, vectorises).
    const MAGIC: f32 = 12_582_912.0;
    let k = (x * std::f32::consts::LOG2_E + MAGIC) - MAGIC;
    // ln 2 split in two so that k * LN2_HI is exact.
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;
    let r = x - k * LN2_HI - k * LN2_LO;
    let p = 1.0
        + r * (1.0
            + r * (0.5
                + r * (1.0 / 6.0
                    + r * (1.0 / 24.0
                        + r * (1.0 / 120.0 + r * (1.0 / 720.0 + r * (1.0 / 5040.0)))))));
    // 2^k: the biased exponent k + 127 (in [1, 127]) read off the mantissa
    // bits of (k + 127 + 2^23), again without a float-to-int cast.
    let biased = (k + (127.0 + 8_388_608.0)).to_bits() & 0x007f_ffff;
    p * f32::from_bits(biased << 23)
}

/// `min` without NaN handling (one `minss`); the scan converter's inputs are
/// never NaN (infinities are fine).
#[inline(always)]
pub fn fmin(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// `max` without NaN handling (one `maxss`).
#[inline(always)]
pub fn fmax(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// `x` clamped to `[lo, hi]`, without NaN handling.
#[inline(always)]
pub fn fclamp(x: f32, lo: f32, hi: f32) -> f32 {
    fmin(fmax(x, lo), hi)
}

/// `floor(x)` as an integer, for `|x| < 2^31` (no libm call).
#[inline(always)]
pub fn floor_i(x: f32) -> i64 {
    let t = x as i64;
    t - ((x < t as f32) as i64)
}

/// `ceil(x)` as an integer, for `|x| < 2^31`.
#[inline(always)]
pub fn ceil_i(x: f32) -> i64 {
    let t = x as i64;
    t + ((x > t as f32) as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_matches_f64() {
        let mut worst = 0.0f64;
        let mut x = 1e-6f32;
        while x <= 1.0 {
            let want = (x as f64).ln();
            let err = ((ln(x) as f64 - want) / want.abs().max(1e-3)).abs();
            worst = worst.max(err);
            x *= 1.0001;
        }
        assert_eq!(ln(1.0), 0.0);
        assert!(worst < 2e-7, "worst relative error {worst:e}");
    }

    #[test]
    fn exp_neg_matches_f64() {
        let mut worst = 0.0f64;
        let mut x = 0.0f32;
        while x > -80.0 {
            let want = (x as f64).exp();
            worst = worst.max(((exp_neg(x) as f64 - want) / want).abs());
            x -= 0.00137;
        }
        assert_eq!(exp_neg(0.0), 1.0);
        assert!(exp_neg(-1000.0) < 1e-37);
        assert!(worst < 2e-7, "worst relative error {worst:e}");
    }
}
