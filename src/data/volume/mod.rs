//! The regular grid (a *volume*): scalar samples on an axis-aligned lattice,
//! kept in their own compact type (u8, u16, i16 or f32: a 512^3 u8 volume
//! stays 128 MiB), with world placement (origin and spacing, as NRRD's
//! `space origin`/`space directions`, NIfTI's axis-aligned sform and VTI's
//! `Origin`/`Spacing`) and 64-bit voxel indices.
//!
//! Convention (VTK image data, NRRD node-centred): sample `(i, j, k)` sits at
//! `origin + (i, j, k) * spacing`; the field between samples is trilinear
//! (scene contract), so it is defined on the box
//! `[origin, origin + (dims - 1) * spacing]` and nowhere else. Index order
//! is x fastest: `idx = i + nx * (j + ny * k)`.

pub mod from_mesh;
pub mod generate;
pub mod report;
pub mod scene;

use std::path::Path;

use crate::error::{Error, Result};

/// The storage type of one voxel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VoxelType {
    /// Unsigned 8-bit.
    U8,
    /// Unsigned 16-bit.
    U16,
    /// Signed 16-bit.
    I16,
    /// 32-bit float.
    F32,
}

impl VoxelType {
    /// Bytes per voxel.
    pub fn size(self) -> usize {
        match self {
            VoxelType::U8 => 1,
            VoxelType::U16 | VoxelType::I16 => 2,
            VoxelType::F32 => 4,
        }
    }

    /// Lower-case name (`u8`, `u16`, `i16`, `f32`).
    pub fn name(self) -> &'static str {
        match self {
            VoxelType::U8 => "u8",
            VoxelType::U16 => "u16",
            VoxelType::I16 => "i16",
            VoxelType::F32 => "f32",
        }
    }
}

/// The voxel values, in their own type.
#[derive(Debug, Clone, PartialEq)]
pub enum Voxels {
    /// Unsigned 8-bit samples.
    U8(Vec<u8>),
    /// Unsigned 16-bit samples.
    U16(Vec<u16>),
    /// Signed 16-bit samples.
    I16(Vec<i16>),
    /// 32-bit float samples (finite; checked by [`Volume::new`]).
    F32(Vec<f32>),
}

impl Voxels {
    /// Number of samples.
    pub fn len(&self) -> u64 {
        (match self {
            Voxels::U8(v) => v.len(),
            Voxels::U16(v) => v.len(),
            Voxels::I16(v) => v.len(),
            Voxels::F32(v) => v.len(),
        }) as u64
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The storage type.
    pub fn voxel_type(&self) -> VoxelType {
        match self {
            Voxels::U8(_) => VoxelType::U8,
            Voxels::U16(_) => VoxelType::U16,
            Voxels::I16(_) => VoxelType::I16,
            Voxels::F32(_) => VoxelType::F32,
        }
    }

    /// Sample `idx` as f32 (exact for every integer type).
    #[inline]
    pub fn get_f32(&self, idx: u64) -> f32 {
        let i = idx as usize;
        match self {
            Voxels::U8(v) => v[i] as f32,
            Voxels::U16(v) => v[i] as f32,
            Voxels::I16(v) => v[i] as f32,
            Voxels::F32(v) => v[i],
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        self.len() * self.voxel_type().size() as u64
    }
}

/// A scalar regular grid with its world placement.
#[derive(Debug, Clone, PartialEq)]
pub struct Volume {
    /// Samples along x, y, z (each >= 1).
    pub dims: [u64; 3],
    /// World distance between neighbouring samples along each axis (> 0).
    pub spacing: [f64; 3],
    /// World position of sample (0, 0, 0).
    pub origin: [f64; 3],
    /// Name of the scalar (the file's array name, or `intensity`).
    pub field: String,
    /// `dims[0] * dims[1] * dims[2]` samples, x fastest.
    pub voxels: Voxels,
}

impl Volume {
    /// Builds a volume, checking that the sample count matches `dims`
    /// (without overflow), that spacing and origin are finite with spacing
    /// positive, and that float samples are finite. `source` names the file
    /// (or generator) for the error message.
    pub fn new(
        source: &Path,
        dims: [u64; 3],
        spacing: [f64; 3],
        origin: [f64; 3],
        field: impl Into<String>,
        voxels: Voxels,
    ) -> Result<Volume> {
        let count = checked_count(dims).ok_or_else(|| {
            Error::data(
                source,
                "dimensions",
                format!("{dims:?}: each must be >= 1 and their product must fit in 64 bits"),
            )
        })?;
        if voxels.len() != count {
            return Err(Error::data(
                source,
                "data",
                format!(
                    "{} samples for dimensions {}x{}x{} (= {count})",
                    voxels.len(),
                    dims[0],
                    dims[1],
                    dims[2]
                ),
            ));
        }
        if let Some(a) = (0..3).find(|&a| !(spacing[a].is_finite() && spacing[a] > 0.0)) {
            return Err(Error::data(
                source,
                "spacing",
                format!(
                    "spacing along axis {a} is {}; it must be finite and > 0",
                    spacing[a]
                ),
            ));
        }
        if origin.iter().any(|v| !v.is_finite()) {
            return Err(Error::data(
                source,
                "origin",
                format!("{origin:?} is not finite"),
            ));
        }
        if let Voxels::F32(v) = &voxels {
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(Error::data(
                    source,
                    format!("voxel {i}"),
                    format!("value {} is not finite", v[i]),
                ));
            }
        }
        Ok(Volume {
            dims,
            spacing,
            origin,
            field: field.into(),
            voxels,
        })
    }

    /// Number of samples (64-bit).
    pub fn len(&self) -> u64 {
        self.voxels.len()
    }

    /// True when the volume holds no samples (never, once built by `new`).
    pub fn is_empty(&self) -> bool {
        self.voxels.is_empty()
    }

    /// The linear index of sample `(i, j, k)`, x fastest.
    #[inline]
    pub fn index(&self, i: u64, j: u64, k: u64) -> u64 {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Sample `(i, j, k)` as f32.
    #[inline]
    pub fn get(&self, i: u64, j: u64, k: u64) -> f32 {
        self.voxels.get_f32(self.index(i, j, k))
    }

    /// Smallest and largest sample value.
    pub fn value_range(&self) -> [f64; 2] {
        fn mm<T: Copy + Into<f64>>(v: &[T]) -> [f64; 2] {
            v.iter()
                .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], &x| {
                    let x: f64 = x.into();
                    [lo.min(x), hi.max(x)]
                })
        }
        match &self.voxels {
            Voxels::U8(v) => mm(v),
            Voxels::U16(v) => mm(v),
            Voxels::I16(v) => mm(v),
            Voxels::F32(v) => mm(v),
        }
    }

    /// World bounding box of the samples (where the trilinear field lives).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let hi = std::array::from_fn(|a| {
            self.origin[a] + (self.dims[a].saturating_sub(1)) as f64 * self.spacing[a]
        });
        (self.origin, hi)
    }

    /// Continuous grid coordinates of a world point (sample (i,j,k) is at
    /// integer coordinates).
    #[inline]
    pub fn world_to_grid(&self, p: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|a| (p[a] - self.origin[a]) / self.spacing[a])
    }

    /// World position of continuous grid coordinates.
    #[inline]
    pub fn grid_to_world(&self, g: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|a| self.origin[a] + g[a] * self.spacing[a])
    }

    /// The trilinear field at continuous grid coordinates `g`, or `None`
    /// outside `[0, dims - 1]` on some axis. f64 throughout (the reference's
    /// building block; renderers keep their own f32 fast paths).
    pub fn trilinear_grid(&self, g: [f64; 3]) -> Option<f64> {
        let mut base = [0u64; 3];
        let mut f = [0.0f64; 3];
        for a in 0..3 {
            let n = self.dims[a];
            if !(g[a] >= 0.0 && g[a] <= (n - 1) as f64) {
                return None;
            }
            let c = (g[a].floor() as u64).min(n.saturating_sub(2));
            base[a] = c;
            f[a] = if n == 1 { 0.0 } else { g[a] - c as f64 };
        }
        let step = |a: usize| u64::from(self.dims[a] > 1);
        let (sx, sy, sz) = (step(0), step(1), step(2));
        let v = |di: u64, dj: u64, dk: u64| {
            self.get(base[0] + di * sx, base[1] + dj * sy, base[2] + dk * sz) as f64
        };
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let c00 = lerp(v(0, 0, 0), v(1, 0, 0), f[0]);
        let c10 = lerp(v(0, 1, 0), v(1, 1, 0), f[0]);
        let c01 = lerp(v(0, 0, 1), v(1, 0, 1), f[0]);
        let c11 = lerp(v(0, 1, 1), v(1, 1, 1), f[0]);
        Some(lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2]))
    }

    /// The trilinear field at a world point, or `None` outside the box.
    pub fn trilinear(&self, p: [f64; 3]) -> Option<f64> {
        self.trilinear_grid(self.world_to_grid(p))
    }
}

/// `dims[0] * dims[1] * dims[2]` if every dimension is >= 1 and the product
/// fits in a u64.
pub fn checked_count(dims: [u64; 3]) -> Option<u64> {
    if dims.contains(&0) {
        return None;
    }
    dims[0].checked_mul(dims[1])?.checked_mul(dims[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Volume {
        // s = x + 10 y + 100 z on a 3x3x3 grid with spacing 2, origin 1.
        let mut v = Vec::new();
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..3 {
                    v.push((i + 10 * j + 100 * k) as f32);
                }
            }
        }
        Volume::new(
            Path::new("t"),
            [3, 3, 3],
            [2.0; 3],
            [1.0; 3],
            "s",
            Voxels::F32(v),
        )
        .unwrap()
    }

    #[test]
    fn trilinear_reproduces_linear_fields() {
        let vol = ramp();
        let p = [2.0, 3.5, 4.25]; // grid (0.5, 1.25, 1.625)
        let s = vol.trilinear(p).unwrap();
        assert!((s - (0.5 + 12.5 + 162.5)).abs() < 1e-12, "{s}");
        assert_eq!(vol.trilinear([0.99, 1.0, 1.0]), None);
        assert_eq!(vol.trilinear([5.0, 5.0, 5.0]), Some(222.0));
        assert_eq!(vol.bounds(), ([1.0; 3], [5.0; 3]));
    }

    #[test]
    fn rejects_bad_shapes() {
        let p = Path::new("x.nrrd");
        let e = Volume::new(
            p,
            [2, 2, 2],
            [1.0; 3],
            [0.0; 3],
            "s",
            Voxels::U8(vec![0; 7]),
        );
        assert!(e.unwrap_err().to_string().contains("7 samples"));
        let e = Volume::new(
            p,
            [1 << 40, 1 << 40, 1],
            [1.0; 3],
            [0.0; 3],
            "s",
            Voxels::U8(vec![]),
        );
        assert!(e.unwrap_err().to_string().contains("64 bits"));
        let e = Volume::new(
            p,
            [1, 1, 1],
            [1.0, 0.0, 1.0],
            [0.0; 3],
            "s",
            Voxels::U8(vec![0]),
        );
        assert!(e.unwrap_err().to_string().contains("axis 1"));
        let e = Volume::new(
            p,
            [1, 1, 1],
            [1.0; 3],
            [0.0; 3],
            "s",
            Voxels::F32(vec![f32::NAN]),
        );
        assert!(e.unwrap_err().to_string().contains("voxel 0"));
    }

    #[test]
    fn flat_axes_are_allowed() {
        let v = Volume::new(
            Path::new("t"),
            [2, 1, 1],
            [1.0; 3],
            [0.0; 3],
            "s",
            Voxels::U8(vec![0, 10]),
        )
        .unwrap();
        assert_eq!(v.trilinear([0.5, 0.0, 0.0]), Some(5.0));
        assert_eq!(v.value_range(), [0.0, 10.0]);
        assert_eq!(v.voxels.bytes(), 2);
    }
}
