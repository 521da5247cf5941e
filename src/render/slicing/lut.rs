//! The transfer function as a lookup table over the raw scalar.
//!
//! Entry `e` of [`LUT_SIZE`] holds the classification at
//! `s_norm = e / (LUT_SIZE - 1)`; a raw scalar `s` maps to the nearest entry
//! `e = round((s - r0) / (r1 - r0) · (LUT_SIZE - 1))`, clamped (the TF is
//! constant outside its control points, which lie in `[0, 1]`). With 4096
//! entries the scalar is rounded by at most `1.2e-4` of the range.
//!
//! Two tables are kept: `sigma` (`[r, g, b, σ]`, `σ = -ln(1 - o)` the
//! extinction per `unit_distance`, for rays whose sample distance varies:
//! perspective) and, for one fixed sample distance `δ`, `baked`
//! (`[r α, g α, b α, α]`, `α = 1 - (1 - o)^(δ / unit_distance)`:
//! premultiplied, opacity-corrected).

use crate::scene::transfer::OPACITY_MAX;
use crate::scene::TransferFunction;

/// Entries of the table.
pub const LUT_SIZE: usize = 4096;

/// The entries of a [`Lut`] with zero opacity (bit `e % 64` of word
/// `e / 64`), with the scalar-to-entry mapping they are indexed by: what
/// empty-space encodings built under a transfer function depend on.
#[derive(Debug, Clone, PartialEq)]
pub struct ZeroSet {
    words: Vec<u64>,
    scale: f32,
    offset: f32,
}

impl ZeroSet {
    /// True when every entry with zero opacity in `self` has zero opacity
    /// in `other` too, under the same mapping: a scalar interval that was
    /// transparent under `self` still is under `other`, so an encoding that
    /// skips `self`'s transparent cells stays exact for `other`.
    pub fn within(&self, other: &ZeroSet) -> bool {
        self.scale == other.scale
            && self.offset == other.offset
            && self
                .words
                .iter()
                .zip(&other.words)
                .all(|(a, b)| a & !b == 0)
    }
}

/// The lookup table of one transfer function over one scalar range.
#[derive(Debug, Clone)]
pub struct Lut {
    /// `[r, g, b, σ]` per entry.
    pub sigma: Vec<[f32; 4]>,
    /// Opacity per entry (per unit distance, not corrected).
    pub opacity: Vec<f32>,
    /// `(LUT_SIZE - 1) / (r1 - r0)`.
    pub scale: f32,
    /// `-r0 · scale + 0.5` (the 0.5 rounds to nearest when truncating).
    pub offset: f32,
    /// Prefix count of entries with non-zero opacity (`nz[e]` = count in
    /// `[0, e)`), for O(1) "is this scalar interval transparent".
    nz: Vec<u32>,
}

impl Lut {
    /// Tabulates `tf` over the raw range `[r0, r1]`.
    pub fn new(tf: &TransferFunction, range: [f64; 2]) -> Lut {
        let mut sigma = Vec::with_capacity(LUT_SIZE);
        let mut opacity = Vec::with_capacity(LUT_SIZE);
        let mut nz = Vec::with_capacity(LUT_SIZE + 1);
        nz.push(0u32);
        for e in 0..LUT_SIZE {
            let s = e as f64 / (LUT_SIZE - 1) as f64;
            let (rgb, o) = tf.eval(s);
            let sg = -(1.0 - o.min(OPACITY_MAX)).ln();
            sigma.push([rgb[0] as f32, rgb[1] as f32, rgb[2] as f32, sg as f32]);
            opacity.push(o as f32);
            nz.push(nz[e] + u32::from(o > 0.0));
        }
        let scale = (LUT_SIZE - 1) as f64 / (range[1] - range[0]);
        Lut {
            sigma,
            opacity,
            scale: scale as f32,
            offset: (-range[0] * scale + 0.5) as f32,
            nz,
        }
    }

    /// The entry of raw scalar `s`.
    #[inline(always)]
    pub fn index(&self, s: f32) -> usize {
        let x = s * self.scale + self.offset; // not mul_add: a libm call without FMA
        super::clamped_index(x, (LUT_SIZE - 1) as f32)
    }

    /// Premultiplied, opacity-corrected entries for a sample distance of
    /// `k = δ / unit_distance`.
    pub fn baked(&self, k: f32) -> Vec<[f32; 4]> {
        self.sigma
            .iter()
            .map(|&[r, g, b, sg]| {
                let a = 1.0 - (-sg * k).exp();
                [r * a, g * a, b * a, a]
            })
            .collect()
    }

    /// True if every entry the raw scalars in `[lo, hi]` can map to has zero
    /// opacity (entries are rounded, so the test covers both neighbours).
    #[inline]
    pub fn transparent(&self, lo: f32, hi: f32) -> bool {
        self.transparent_entries(self.index(lo), self.index(hi))
    }

    /// The entries with zero opacity, with this table's mapping.
    pub fn zero_set(&self) -> ZeroSet {
        let mut words = vec![0u64; LUT_SIZE.div_ceil(64)];
        for e in 0..LUT_SIZE {
            if self.nz[e + 1] == self.nz[e] {
                words[e / 64] |= 1 << (e % 64);
            }
        }
        ZeroSet {
            words,
            scale: self.scale,
            offset: self.offset,
        }
    }

    /// True if every entry from `a` to `b` (inclusive, `a <= b`) has zero
    /// opacity.
    #[inline(always)]
    pub fn transparent_entries(&self, a: usize, b: usize) -> bool {
        self.nz[b + 1] == self.nz[a]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indices_and_transparency() {
        let tf = TransferFunction::from_rows(
            &[
                [0.0, 1.0, 1.0, 1.0, 0.0],
                [0.5, 1.0, 1.0, 1.0, 0.0],
                [1.0, 1.0, 0.0, 0.0, 0.5],
            ],
            1.0,
        );
        let lut = Lut::new(&tf, [100.0, 200.0]);
        assert_eq!(lut.index(100.0), 0);
        assert_eq!(lut.index(200.0), LUT_SIZE - 1);
        assert_eq!(lut.index(-5.0), 0);
        assert_eq!(lut.index(1e9), LUT_SIZE - 1);
        assert!(lut.transparent(0.0, 149.0));
        assert!(!lut.transparent(140.0, 151.0));
        let b = lut.baked(2.0);
        let top = b[LUT_SIZE - 1];
        assert!((top[3] - 0.75).abs() < 1e-6, "{top:?}");
        assert!((top[0] - 0.75).abs() < 1e-6);
    }
}
