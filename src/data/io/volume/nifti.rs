//! Reader for NIfTI-1 single files (`.nii`, `.nii.gz`; magic `n+1`).
//!
//! A small reader of the 348-byte header (nifti1.h): `sizeof_hdr` (348,
//! and its byte order gives the file's), `dim[0..8]` (i16 at byte 40),
//! `datatype` (i16 at 70), `pixdim[0..8]` (f32 at 76), `vox_offset` (f32 at
//! 108), `scl_slope`/`scl_inter` (f32 at 112/116), `qform_code`/
//! `sform_code` (i16 at 252/254), the quaternion (f32 at 256..280) and
//! `srow_x/y/z` (f32 at 280..328), `magic` (344).
//!
//! Placement, in NIfTI's order of preference: `sform_code > 0` gives
//! `world = S (i, j, k, 1)` with the rows `srow_*`, so `d_a` is column `a`
//! of S and the origin its last column; else `qform_code > 0` gives
//! `world = R diag(pixdim_1, pixdim_2, qfac pixdim_3) (i, j, k) + qoffset`
//! with R the rotation of the quaternion (b, c, d), `a = sqrt(1 - b^2 -
//! c^2 - d^2)`; else spacing `pixdim_1..3` at origin 0 (NIfTI "method 1").
//! The directions must be axis-aligned (see [`placement`](super::placement);
//! negative ones, as in LAS-stored files, are flipped).
//!
//! `scl_slope != 0` and not the identity (slope 1, intercept 0) turns the
//! samples into f32 `slope * v + inter`, as NIfTI readers must; otherwise
//! the stored type is kept. 4D and higher (`dim[4..] > 1`), complex and RGB
//! data, NIfTI-2 and the two-file `ni1` form are refused by name.

use std::io::Read;
use std::path::Path;

use super::placement::{apply_flips, axis_aligned};
use super::samples::{decode_voxels, payload_bytes, MAX_DEFLATE_RATIO};
use crate::data::io::numeric::NumType;
use crate::data::io::read_bytes;
use crate::data::{volume::checked_count, Volume, Voxels};
use crate::error::{Error, Result};

/// Size of the NIfTI-1 header.
pub const HEADER_BYTES: usize = 348;

/// Reads a `.nii` or `.nii.gz` file (gzip recognised by its magic bytes,
/// whatever the name). `field` names the scalar (empty: `intensity`).
pub fn read(path: &Path, field: &str) -> Result<Volume> {
    let d = read_bytes(path)?;
    parse(&d, path, field)
}

/// Little reader over the header bytes in the file's byte order.
struct Hdr<'a> {
    b: &'a [u8],
    big: bool,
}

impl Hdr<'_> {
    fn i16(&self, at: usize) -> i16 {
        let a = [self.b[at], self.b[at + 1]];
        if self.big {
            i16::from_be_bytes(a)
        } else {
            i16::from_le_bytes(a)
        }
    }
    fn f32(&self, at: usize) -> f32 {
        let a = [self.b[at], self.b[at + 1], self.b[at + 2], self.b[at + 3]];
        if self.big {
            f32::from_be_bytes(a)
        } else {
            f32::from_le_bytes(a)
        }
    }
    fn f32s<const N: usize>(&self, at: usize) -> [f64; N] {
        std::array::from_fn(|i| self.f32(at + 4 * i) as f64)
    }
}

fn datatype(code: i16) -> std::result::Result<NumType, String> {
    Ok(match code {
        2 => NumType::U8,
        4 => NumType::I16,
        8 => NumType::I32,
        16 => NumType::F32,
        64 => NumType::F64,
        256 => NumType::I8,
        512 => NumType::U16,
        768 => NumType::U32,
        1024 => NumType::I64,
        1280 => NumType::U64,
        32 | 1792 | 2048 => return Err(format!("datatype {code} (complex) is not supported")),
        128 | 2304 => return Err(format!("datatype {code} (RGB/RGBA) is not supported")),
        1536 => return Err("datatype 1536 (float128) is not supported".into()),
        _ => return Err(format!("datatype {code} is not a NIfTI-1 scalar type")),
    })
}

/// Parses NIfTI-1 bytes (gzip-compressed or not).
pub fn parse(file: &[u8], path: &Path, field: &str) -> Result<Volume> {
    let gz = file.starts_with(&[0x1f, 0x8b]);
    let head = if gz {
        let mut h = Vec::new();
        flate2::read::MultiGzDecoder::new(file)
            .take(HEADER_BYTES as u64)
            .read_to_end(&mut h)
            .map_err(|e| Error::data(path, "header", format!("gzip data is corrupt: {e}")))?;
        h
    } else {
        file[..file.len().min(HEADER_BYTES)].to_vec()
    };
    if head.len() < HEADER_BYTES {
        return Err(Error::data(
            path,
            "header",
            format!(
                "truncated: {} bytes, a NIfTI-1 header has {HEADER_BYTES}",
                head.len()
            ),
        ));
    }
    let sz = |big| {
        let a = [head[0], head[1], head[2], head[3]];
        if big {
            i32::from_be_bytes(a)
        } else {
            i32::from_le_bytes(a)
        }
    };
    let big = match (sz(false), sz(true)) {
        (348, _) => false,
        (_, 348) => true,
        (540, _) | (_, 540) => {
            return Err(Error::data(
                path,
                "sizeof_hdr (byte 0)",
                "this is a NIfTI-2 file; pvrsim reads NIfTI-1 (convert with e.g. nibabel)",
            ))
        }
        (v, _) => {
            return Err(Error::data(
                path,
                "sizeof_hdr (byte 0)",
                format!("{v} is not 348 in either byte order: not a NIfTI-1 file"),
            ))
        }
    };
    let h = Hdr { b: &head, big };
    let magic = &head[344..348];
    if magic == b"ni1\0" {
        return Err(Error::data(
            path,
            "magic (byte 344)",
            "\"ni1\": a two-file NIfTI header (.hdr/.img); pvrsim reads single .nii files",
        ));
    }
    if magic != b"n+1\0" {
        return Err(Error::data(
            path,
            "magic (byte 344)",
            format!("{magic:?} is not \"n+1\\0\""),
        ));
    }
    let dim: [i16; 8] = std::array::from_fn(|i| h.i16(40 + 2 * i));
    if !(1..=7).contains(&dim[0]) {
        return Err(Error::data(
            path,
            "dim[0] (byte 40)",
            format!("{} dimensions: must be 1..7", dim[0]),
        ));
    }
    let nd = dim[0] as usize;
    for (a, &n) in dim.iter().enumerate().take(nd + 1).skip(1) {
        if n < 1 {
            return Err(Error::data(
                path,
                format!("dim[{a}] (byte {})", 40 + 2 * a),
                format!("{n} is not a positive size"),
            ));
        }
        if a > 3 && n > 1 {
            return Err(Error::data(
                path,
                format!("dim[{a}] (byte {})", 40 + 2 * a),
                format!(
                    "{n}: {nd}-D data (time series or vectors) is not supported; extract one 3D volume (e.g. fslroi)"
                ),
            ));
        }
    }
    let size = |a: usize| if a <= nd { dim[a] as u64 } else { 1 };
    let dims = [size(1), size(2), size(3)];
    let ty = datatype(h.i16(70)).map_err(|m| Error::data(path, "datatype (byte 70)", m))?;
    let count = checked_count(dims).unwrap_or(u64::MAX); // i16 sizes cannot overflow
    let nbytes = payload_bytes(path, "dim (byte 40)", count, ty)?;
    let vox_offset = h.f32(108);
    if !(vox_offset.is_finite() && vox_offset >= 0.0 && vox_offset.fract() == 0.0) {
        return Err(Error::data(
            path,
            "vox_offset (byte 108)",
            format!("{vox_offset} is not a non-negative whole byte offset"),
        ));
    }
    let off = (vox_offset as u64).max(HEADER_BYTES as u64);
    // vox_offset is a float: a huge one saturates to u64::MAX in the cast,
    // so the sum is checked rather than left to wrap.
    let total = off.checked_add(nbytes).ok_or_else(|| {
        Error::data(
            path,
            "vox_offset (byte 108)",
            format!("{vox_offset} is past any file: offset + {nbytes} data bytes overflow"),
        )
    })?;

    let data = if gz {
        let max = (file.len() as u64).saturating_mul(MAX_DEFLATE_RATIO);
        if total > max {
            return Err(Error::data(
                path,
                "data",
                format!("the header needs {total} bytes but {} gzip bytes can hold at most {max}: truncated file or wrong header", file.len()),
            ));
        }
        let mut all = Vec::new();
        flate2::read::MultiGzDecoder::new(file)
            .take(total)
            .read_to_end(&mut all)
            .map_err(|e| Error::data(path, "data", format!("gzip data is corrupt: {e}")))?;
        if (all.len() as u64) < total {
            return Err(Error::data(
                path,
                "data",
                format!(
                    "data is truncated: {} bytes after decompression, vox_offset {off} + {dims:?} of {ty:?} need {total}",
                    all.len()
                ),
            ));
        }
        all.drain(..off as usize);
        all
    } else {
        if (file.len() as u64) < total {
            return Err(Error::data(
                path,
                "data",
                format!(
                    "data is truncated: the file has {} bytes, vox_offset {off} + {dims:?} of {ty:?} need {total}",
                    file.len()
                ),
            ));
        }
        file[off as usize..total as usize].to_vec()
    };
    let (mut voxels, lossy) = decode_voxels(data, ty, big);

    let (slope, inter) = (h.f32(112), h.f32(116));
    if slope != 0.0 && slope.is_finite() && inter.is_finite() && !(slope == 1.0 && inter == 0.0) {
        let n = voxels.len();
        voxels = Voxels::F32((0..n).map(|i| slope * voxels.get_f32(i) + inter).collect());
        tracing::info!(
            "{}: scl_slope {slope}, scl_inter {inter} applied (samples stored as f32)",
            path.display()
        );
    } else if lossy {
        tracing::warn!("{}: {ty:?} samples are stored as f32", path.display());
    }

    let pixdim: [f64; 8] = h.f32s(76);
    let (qcode, scode) = (h.i16(252), h.i16(254));
    let (dirs, origin, what) = if scode > 0 {
        let r: [[f64; 4]; 3] = [h.f32s(280), h.f32s(296), h.f32s(312)];
        (
            std::array::from_fn(|c| [r[0][c], r[1][c], r[2][c]]),
            [r[0][3], r[1][3], r[2][3]],
            "sform (srow_x/y/z, byte 280)",
        )
    } else if qcode > 0 {
        let [b, c, d]: [f64; 3] = h.f32s(256);
        let a = (1.0 - (b * b + c * c + d * d)).max(0.0).sqrt();
        let rot = [
            [
                a * a + b * b - c * c - d * d,
                2.0 * (b * c - a * d),
                2.0 * (b * d + a * c),
            ],
            [
                2.0 * (b * c + a * d),
                a * a + c * c - b * b - d * d,
                2.0 * (c * d - a * b),
            ],
            [
                2.0 * (b * d - a * c),
                2.0 * (c * d + a * b),
                a * a + d * d - c * c - b * b,
            ],
        ];
        let qfac = if pixdim[0] < 0.0 { -1.0 } else { 1.0 };
        let s = [pixdim[1], pixdim[2], qfac * pixdim[3]];
        (
            std::array::from_fn(|col| std::array::from_fn(|row| rot[row][col] * s[col])),
            h.f32s(268),
            "qform (quatern_b/c/d, byte 256)",
        )
    } else {
        let s = |a: usize| if pixdim[a] > 0.0 { pixdim[a] } else { 1.0 };
        (
            [[s(1), 0.0, 0.0], [0.0, s(2), 0.0], [0.0, 0.0, s(3)]],
            [0.0; 3],
            "pixdim (byte 76)",
        )
    };
    let p = axis_aligned(path, what, dims, dirs, origin)?;
    apply_flips(&mut voxels, dims, &p);
    let name = if field.is_empty() { "intensity" } else { field };
    Volume::new(path, dims, p.spacing, p.origin, name, voxels)
}
