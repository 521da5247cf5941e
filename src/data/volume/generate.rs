//! Test volumes of any size: the splatting paper's analytic hydrogen atom,
//! the Marschner–Lobb test signal, and resampling of an existing grid.

use std::path::Path;

use rayon::prelude::*;

use super::{checked_count, Volume, VoxelType, Voxels};
use crate::error::{Error, Result};

/// The hydrogen-atom volume of KVS (`kvs::HydrogenVolumeData`), used by the
/// splatting paper: an `n^3` u8 grid over the 32-unit cube centred on the
/// origin. Sample `(i, j, k)` sits at `x = (32 / n) (i - n/2)` (likewise y,
/// z), i.e. origin `-16`, spacing `32 / n`, last sample at `16 - 32/n`
/// (exactly KVS's positions). With `r = |x|` and `cos(theta) = z / r`:
///
/// `phi = 6 r^2 e^(-r/2) (3 cos^2(theta) - 1)`  (the 3d_z2 orbital shape),
/// `value = trunc(min(phi^2, 255))`, and `0` at `r = 0`.
///
/// The values peak (clamped at 255) in the two lobes along z and the ring
/// in the xy plane around `r = 4`.
pub fn hydrogen(n: u64) -> Volume {
    let n = n.max(2);
    let h = 32.0 / n as f64;
    let half = n as f64 / 2.0;
    let nn = (n * n) as usize;
    let mut v = vec![0u8; nn * n as usize];
    v.par_chunks_mut(nn).enumerate().for_each(|(k, slab)| {
        let z = h * (k as f64 - half);
        for j in 0..n as usize {
            let y = h * (j as f64 - half);
            for i in 0..n as usize {
                let x = h * (i as f64 - half);
                let r = (x * x + y * y + z * z).sqrt();
                slab[i + j * n as usize] = if r == 0.0 {
                    0
                } else {
                    let c = z / r;
                    let phi = 6.0 * r * r * (-r / 2.0).exp() * (3.0 * c * c - 1.0);
                    (phi * phi).min(255.0) as u8
                };
            }
        }
    });
    Volume::new(
        Path::new("generate hydrogen"),
        [n; 3],
        [h; 3],
        [-16.0; 3],
        "hydrogen",
        Voxels::U8(v),
    )
    .expect("hydrogen: valid by construction")
}

/// The Marschner–Lobb signal (Marschner & Lobb 1994) with the standard
/// parameters `f_M = 6`, `alpha = 0.25`, sampled on an `n^3` f32 grid over
/// `[-1, 1]^3` (spacing `2 / (n - 1)`):
///
/// `rho(x, y, z) = (1 - sin(pi z / 2) + alpha (1 + rho_r(sqrt(x^2 + y^2))))
///  / (2 (1 + alpha))`, with `rho_r(r) = cos(2 pi f_M cos(pi r / 2))`.
///
/// Values lie in [0, 1].
pub fn marschner_lobb(n: u64) -> Volume {
    const F_M: f64 = 6.0;
    const ALPHA: f64 = 0.25;
    let n = n.max(2);
    let h = 2.0 / (n - 1) as f64;
    let nn = (n * n) as usize;
    let pi = std::f64::consts::PI;
    let mut v = vec![0f32; nn * n as usize];
    v.par_chunks_mut(nn).enumerate().for_each(|(k, slab)| {
        let z = -1.0 + h * k as f64;
        for j in 0..n as usize {
            let y = -1.0 + h * j as f64;
            for i in 0..n as usize {
                let x = -1.0 + h * i as f64;
                let r = (x * x + y * y).sqrt();
                let rho_r = (2.0 * pi * F_M * (pi * r / 2.0).cos()).cos();
                let rho =
                    (1.0 - (pi * z / 2.0).sin() + ALPHA * (1.0 + rho_r)) / (2.0 * (1.0 + ALPHA));
                slab[i + j * n as usize] = rho as f32;
            }
        }
    });
    Volume::new(
        Path::new("generate marschner-lobb"),
        [n; 3],
        [h; 3],
        [-1.0; 3],
        "marschner-lobb",
        Voxels::F32(v),
    )
    .expect("marschner-lobb: valid by construction")
}

/// Resampling filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Filter {
    /// The trilinear field at the new sample positions.
    Trilinear,
    /// The mean of the source samples within half a new spacing of the new
    /// sample (per axis); trilinear where that footprint holds no sample
    /// (upsampling).
    Box,
}

/// Resamples `src` to `dims` samples over the same world box (first and
/// last samples keep their positions: new spacing `(n - 1) s / (m - 1)`;
/// an axis of one sample keeps its spacing). The voxel type is kept:
/// integer types are rounded to nearest and clamped to the type's range.
pub fn resample(src: &Volume, dims: [u64; 3], filter: Filter) -> Result<Volume> {
    resample_as(src, dims, filter, None)
}

/// [`resample`] into u8: the source's value range `[lo, hi]` maps linearly
/// onto `0..=255` (rounded), as 8-bit textures hold the data.
pub fn resample_u8(src: &Volume, dims: [u64; 3], filter: Filter) -> Result<Volume> {
    resample_as(src, dims, filter, Some(VoxelType::U8))
}

/// Resamples slab by slab straight into the output type (no full-size f64
/// buffer: a 512 x 512 x 1024 u8 result holds 256 MiB, not 2 GiB).
fn resample_as(
    src: &Volume,
    dims: [u64; 3],
    filter: Filter,
    to: Option<VoxelType>,
) -> Result<Volume> {
    let n = src.dims;
    let ratio: [f64; 3] = std::array::from_fn(|a| {
        if dims[a] > 1 {
            (n[a] - 1) as f64 / (dims[a] - 1) as f64
        } else {
            0.0
        }
    });
    let spacing: [f64; 3] = std::array::from_fn(|a| {
        if dims[a] > 1 && n[a] > 1 {
            src.spacing[a] * ratio[a]
        } else {
            src.spacing[a]
        }
    });
    let plane = (dims[0] * dims[1]) as usize;
    let total = checked_count(dims)
        .ok_or_else(|| Error::Invalid(format!("resample: {dims:?} samples overflow")))?
        as usize;
    let value = |i: u64, j: u64, k: u64| -> f64 {
        let g = [
            i as f64 * ratio[0],
            j as f64 * ratio[1],
            k as f64 * ratio[2],
        ];
        match filter {
            Filter::Box => box_mean(src, g, ratio),
            Filter::Trilinear => None,
        }
        .or_else(|| src.trilinear_grid(g.map(|x| x.max(0.0))))
        .unwrap_or(0.0)
    };
    fn fill<T: Copy + Default + Send>(
        total: usize,
        plane: usize,
        dims: [u64; 3],
        value: &(dyn Fn(u64, u64, u64) -> f64 + Sync),
        conv: impl Fn(f64) -> T + Sync,
    ) -> Vec<T> {
        let mut out = vec![T::default(); total];
        out.par_chunks_mut(plane).enumerate().for_each(|(k, slab)| {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    slab[(i + j * dims[0]) as usize] = conv(value(i, j, k as u64));
                }
            }
        });
        out
    }
    let voxels = match to {
        Some(VoxelType::U8) => {
            let [lo, hi] = src.value_range();
            let scale = if hi > lo { 255.0 / (hi - lo) } else { 0.0 };
            Voxels::U8(fill(total, plane, dims, &value, |x| {
                ((x - lo) * scale).round().clamp(0.0, 255.0) as u8
            }))
        }
        _ => match src.voxels.voxel_type() {
            VoxelType::U8 => Voxels::U8(fill(total, plane, dims, &value, |x| {
                x.round().clamp(0.0, 255.0) as u8
            })),
            VoxelType::U16 => Voxels::U16(fill(total, plane, dims, &value, |x| {
                x.round().clamp(0.0, 65535.0) as u16
            })),
            VoxelType::I16 => Voxels::I16(fill(total, plane, dims, &value, |x| {
                x.round().clamp(-32768.0, 32767.0) as i16
            })),
            VoxelType::F32 => Voxels::F32(fill(total, plane, dims, &value, |x| x as f32)),
        },
    };
    Volume::new(
        Path::new("resample"),
        dims,
        spacing,
        src.origin,
        src.field.clone(),
        voxels,
    )
}

/// Mean of the source samples `i` with `|i - g| <= r / 2` on every axis,
/// or `None` when there are none.
fn box_mean(src: &Volume, g: [f64; 3], r: [f64; 3]) -> Option<f64> {
    let range = |a: usize| {
        let lo = (g[a] - r[a] / 2.0).ceil().max(0.0) as u64;
        let hi = ((g[a] + r[a] / 2.0).floor() as u64).min(src.dims[a] - 1);
        (lo, hi)
    };
    let (x0, x1) = range(0);
    let (y0, y1) = range(1);
    let (z0, z1) = range(2);
    if x0 > x1 || y0 > y1 || z0 > z1 {
        return None;
    }
    let mut sum = 0.0;
    for k in z0..=z1 {
        for j in y0..=y1 {
            for i in x0..=x1 {
                sum += src.get(i, j, k) as f64;
            }
        }
    }
    Some(sum / ((x1 - x0 + 1) * (y1 - y0 + 1) * (z1 - z0 + 1)) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hydrogen_matches_the_formula_and_kvs_positions() {
        let v = hydrogen(64);
        assert_eq!(
            (v.dims, v.spacing, v.origin),
            ([64; 3], [0.5; 3], [-16.0; 3])
        );
        // Centre sample (32, 32, 32) is r = 0 -> 0.
        assert_eq!(v.get(32, 32, 32), 0.0);
        // On the z axis at z = 4 (k = 40): phi = 6 * 16 * e^-2 * 2.
        let phi: f64 = 6.0 * 16.0 * (-2.0f64).exp() * 2.0;
        assert_eq!(v.get(32, 32, 40) as f64, (phi * phi).min(255.0).trunc());
        // In the xy plane at x = 2 (i = 36): cos = 0, phi = -6 * 4 * e^-1.
        let phi: f64 = -6.0 * 4.0 * (-1.0f64).exp();
        assert_eq!(v.get(36, 32, 32) as f64, (phi * phi).trunc());
        // Symmetric under z -> -z about the centre sample.
        assert_eq!(v.get(30, 33, 36), v.get(30, 33, 28));
        assert_eq!(v.value_range(), [0.0, 255.0]);
    }

    #[test]
    fn marschner_lobb_values() {
        let v = marschner_lobb(41);
        assert_eq!(v.bounds(), ([-1.0; 3], [1.0; 3]));
        // At the origin: r = 0, rho_r = cos(12 pi) = 1, rho = (1 + 0.5) / 2.5.
        assert!((v.get(20, 20, 20) as f64 - 0.6).abs() < 1e-6);
        // At z = 1 (top face), x = y = 0: (1 - 1 + 0.5) / 2.5 = 0.2.
        assert!((v.get(20, 20, 40) as f64 - 0.2).abs() < 1e-6);
        let [lo, hi] = v.value_range();
        assert!(lo >= -1e-6 && hi <= 1.0 + 1e-6);
    }

    #[test]
    fn resample_keeps_linear_fields_and_box_averages() {
        // s = 2 i + 3 j + k on 5^3, u16.
        let mut s = Vec::new();
        for k in 0..5u16 {
            for j in 0..5u16 {
                for i in 0..5u16 {
                    s.push(2 * i + 3 * j + k);
                }
            }
        }
        let src = Volume::new(
            Path::new("t"),
            [5; 3],
            [1.0; 3],
            [0.0; 3],
            "s",
            Voxels::U16(s),
        )
        .unwrap();
        let up = resample(&src, [9; 3], Filter::Trilinear).unwrap();
        assert_eq!(up.spacing, [0.5; 3]);
        assert_eq!(up.bounds(), src.bounds());
        // New (1, 2, 3) is source (0.5, 1, 1.5): s = 1 + 3 + 1.5 = 5.5, rounds to 6.
        assert_eq!(up.get(1, 2, 3), 6.0);
        let down = resample(&src, [3; 3], Filter::Box).unwrap();
        // New sample 1 sits at source 2 with footprint [1, 3]: mean = value at 2.
        assert_eq!(down.get(1, 1, 1), 12.0);
        // Corner footprint [0, 1]: mean of i, j, k in {0, 1} = 3.
        assert_eq!(down.get(0, 0, 0), 3.0);
    }
}
