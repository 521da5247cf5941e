//! Float-to-index conversion for the hot loops.
//!
//! `x as usize` from f32 is saturating and must handle values past 2^63
//! (x86-64 has no unsigned conversion below AVX-512): about ten instructions
//! per conversion. slice3d's sample loop did four of them per sample (three
//! cell coordinates and the lookup-table index), a sixth of its
//! instructions (cachegrind, colin27). Clamping first makes the value a
//! valid index, after which one truncating conversion is exact.

/// `x` clamped into `[lo, hi]`, `NaN` to `lo`: one `maxss` and one `minss`
/// (`f32::max`/`min` add NaN handling, two more instructions each).
#[inline(always)]
pub fn clamp_fast(x: f32, lo: f32, hi: f32) -> f32 {
    let x = if x > lo { x } else { lo };
    if x < hi {
        x
    } else {
        hi
    }
}

/// `floor(x)` of `x` clamped into `[0, hi]`, as an index (`NaN` gives 0).
/// Equal to `(x.max(0.0) as usize).min(hi as usize)` for every `x` when
/// `hi` is a whole number below 2^63.
#[inline(always)]
pub fn clamped_index(x: f32, hi: f32) -> usize {
    debug_assert!((0.0..9.2e18).contains(&hi) && hi.fract() == 0.0);
    // NaN becomes 0, so `x` is finite from here on.
    let x = clamp_fast(x, 0.0, hi);
    // SAFETY: `x` is finite and in `[0, hi]` with `hi < 2^63`, so its
    // truncation fits in i64 (the precondition of `to_int_unchecked`).
    let i: i64 = unsafe { x.to_int_unchecked() };
    i as usize
}

#[cfg(test)]
mod tests {
    use super::clamped_index;
    use proptest::prelude::*;

    proptest! {
        /// The same index as the saturating conversion then `min`.
        #[test]
        fn equals_saturating_conversion(x in any::<f32>(), hi in 0u32..100_000) {
            let h = hi as f32;
            let want = if x.is_nan() { 0 } else { (x.max(0.0) as usize).min(hi as usize) };
            prop_assert_eq!(clamped_index(x, h), want);
        }
    }

    #[test]
    fn clamp_fast_edges() {
        use super::clamp_fast;
        assert_eq!(clamp_fast(f32::NAN, 1.0, 2.0), 1.0);
        assert_eq!(clamp_fast(0.5, 1.0, 2.0), 1.0);
        assert_eq!(clamp_fast(1.5, 1.0, 2.0), 1.5);
        assert_eq!(clamp_fast(f32::INFINITY, 1.0, 2.0), 2.0);
    }

    #[test]
    fn edges() {
        assert_eq!(clamped_index(f32::NAN, 7.0), 0);
        assert_eq!(clamped_index(f32::INFINITY, 7.0), 7);
        assert_eq!(clamped_index(f32::NEG_INFINITY, 7.0), 0);
        assert_eq!(clamped_index(-0.5, 7.0), 0);
        assert_eq!(clamped_index(6.999, 7.0), 6);
        assert_eq!(clamped_index(7.0, 7.0), 7);
    }
}
