//! Voxel types as texels: read as f32 in the hot loops, monomorphised per
//! type so that a u8 volume is sampled as u8 (one byte per load).

use crate::data::Voxels;

/// A voxel storage type the slicers sample.
pub trait Texel: Copy + Send + Sync + 'static {
    /// The value as f32 (exact for u8, u16, i16).
    fn f(self) -> f32;
}

impl Texel for u8 {
    #[inline(always)]
    fn f(self) -> f32 {
        self as f32
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
