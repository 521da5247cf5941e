//! Voxel types as texels: read as f32 in the hot loops, monomorphised per
//! type so that a u8 volume is sampled as u8 (one byte per load).

use crate::data::Voxels;

/// A voxel storage type the slicers sample.
pub trait Texel: Copy + Send + Sync + 'static {
    /// Trilinear interpolation at fractions `f` of the cell whose corners
    /// are `s[0]`, `s[1]` (x), `+ r` (y), `+ sl` (z) (row and slab strides
    /// of the layout). The default converts the 8 corners and calls
    /// [`trilinear`]; `u8` does the same operations four lanes at a time
    /// (SSE2, the x86-64 baseline), in the same order, so the result is
    /// the same bit for bit.
    #[inline(always)]
    fn trilinear(s: &[Self], r: usize, sl: usize, f: [f32; 3]) -> f32 {
        let s = &s[..sl + r + 2];
        trilinear(
            [
                s[0],
                s[1],
                s[r],
                s[r + 1],
                s[sl],
                s[sl + 1],
                s[sl + r],
                s[sl + r + 1],
            ]
            .map(Texel::f),
            f,
        )
    }

    /// The value as f32 (exact for u8, u16, i16).
    fn f(self) -> f32;

    /// The value itself when the type is `u8` (so per-value tables of 256
    /// entries can stand for per-voxel work), else `None`.
    #[inline(always)]
    fn byte(self) -> Option<u8> {
        None
    }
}

impl Texel for u8 {
    #[inline(always)]
    fn f(self) -> f32 {
        self as f32
    }

    #[inline(always)]
    fn byte(self) -> Option<u8> {
        Some(self)
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn trilinear(s: &[u8], r: usize, sl: usize, f: [f32; 3]) -> f32 {
        use std::arch::x86_64::*;
        let s = &s[..sl + r + 2];
        let pair = |i: usize| u16::from_le_bytes([s[i], s[i + 1]]) as u64;
        // v0 v1 | v2 v3 (y + 1) | v4 v5 (z + 1) | v6 v7, one byte each.
        let bytes = pair(0) | pair(r) << 16 | pair(sl) << 32 | pair(sl + r) << 48;
        // SAFETY: SSE2 is part of the x86-64 baseline; no memory is touched.
        unsafe {
            let z = _mm_setzero_si128();
            let w = _mm_unpacklo_epi8(_mm_cvtsi64_si128(bytes as i64), z);
            let lo = _mm_cvtepi32_ps(_mm_unpacklo_epi16(w, z)); // v0..v3
            let hi = _mm_cvtepi32_ps(_mm_unpackhi_epi16(w, z)); // v4..v7
                                                                // x: a = (v0, v2, v4, v6), b = (v1, v3, v5, v7).
            let a = _mm_shuffle_ps::<0x88>(lo, hi);
            let b = _mm_shuffle_ps::<0xDD>(lo, hi);
            let x = _mm_add_ps(_mm_mul_ps(_mm_sub_ps(b, a), _mm_set1_ps(f[0])), a);
            // x = (x00, x10, x01, x11); y: a = (x00, x01), b = (x10, x11).
            let a = _mm_shuffle_ps::<0x88>(x, x);
            let b = _mm_shuffle_ps::<0xDD>(x, x);
            let y = _mm_add_ps(_mm_mul_ps(_mm_sub_ps(b, a), _mm_set1_ps(f[1])), a);
            let y0 = _mm_cvtss_f32(y);
            let y1 = _mm_cvtss_f32(_mm_shuffle_ps::<0x55>(y, y));
            (y1 - y0) * f[2] + y0
        }
    }
}
impl Texel for u16 {
    #[inline(always)]
    fn f(self) -> f32 {
        self as f32
    }
}
impl Texel for i16 {
    #[inline(always)]
    fn f(self) -> f32 {
        self as f32
    }
}
impl Texel for f32 {
    #[inline(always)]
    fn f(self) -> f32 {
        self
    }
}

/// Calls `$body` with `$data` bound to the voxel slice in its own type.
#[macro_export]
#[doc(hidden)]
macro_rules! with_texels {
    ($voxels:expr, $data:ident => $body:expr) => {
        match $voxels {
            $crate::data::Voxels::U8(v) => {
                let $data: &[u8] = v;
                $body
            }
            $crate::data::Voxels::U16(v) => {
                let $data: &[u16] = v;
                $body
            }
            $crate::data::Voxels::I16(v) => {
                let $data: &[i16] = v;
                $body
            }
            $crate::data::Voxels::F32(v) => {
                let $data: &[f32] = v;
                $body
            }
        }
    };
}

/// Bytes of one voxel of `v`.
pub fn voxel_bytes(v: &Voxels) -> u64 {
    v.voxel_type().size() as u64
}

#[inline(always)]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    // Not `mul_add`: without a target FMA unit it is a slow library call.
    (b - a) * t + a
}

/// Trilinear interpolation of corners `v` (x fastest, then y, then z) at
/// fractions `f`: x first, then y, then z.
#[inline(always)]
pub fn trilinear(v: [f32; 8], f: [f32; 3]) -> f32 {
    let x00 = lerp(v[0], v[1], f[0]);
    let x10 = lerp(v[2], v[3], f[0]);
    let x01 = lerp(v[4], v[5], f[0]);
    let x11 = lerp(v[6], v[7], f[0]);
    lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The u8 lanes give the scalar result bit for bit.
        #[test]
        fn u8_trilinear_equals_scalar(v in proptest::array::uniform32(any::<u8>()), f in proptest::array::uniform3(0f32..=1.0)) {
            let (r, sl) = (3usize, 7usize);
            let s = &v[..];
            let want = trilinear(
                [s[0], s[1], s[r], s[r + 1], s[sl], s[sl + 1], s[sl + r], s[sl + r + 1]].map(|x| x as f32),
                f,
            );
            prop_assert_eq!(u8::trilinear(s, r, sl, f).to_bits(), want.to_bits());
        }
    }
}
