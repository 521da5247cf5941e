//! Turning the bytes of a grid file into [`Voxels`], shared by every volume
//! reader: the sample types the formats name, decoding either byte order,
//! and the size checks that come *before* any allocation a header asks for.
//!
//! Storage policy (issue 9: voxels stay in a compact type): u8, u16, i16 and
//! f32 are kept as they are; i8 widens to i16 (exact). 32- and 64-bit
//! integers and f64 have no compact exact home: they are converted to f32,
//! which is exact for integers up to 2^24 and keeps 24 bits of mantissa for
//! f64; the reader logs a warning naming the file when it does this, and
//! `pvrsim info` shows the stored type.

use std::io::Read;
use std::path::Path;

use crate::data::io::numeric::NumType;
use crate::data::Voxels;
use crate::error::{Error, Result};

/// Largest decompressed payload we accept, whatever a header claims: 64 GiB
/// (a 4096^3 u8 grid; far beyond one machine's renderers).
pub const MAX_PAYLOAD_BYTES: u64 = 64 << 30;

/// Deflate cannot expand by more than about 1032:1; a header claiming more
/// than this many decompressed bytes per compressed byte is lying (or the
/// file is truncated) and is refused before anything is allocated.
pub const MAX_DEFLATE_RATIO: u64 = 1100;

/// Bytes of `count` samples of `ty`, or an error naming `path`/`location`
/// when the product overflows or exceeds [`MAX_PAYLOAD_BYTES`].
pub fn payload_bytes(path: &Path, location: &str, count: u64, ty: NumType) -> Result<u64> {
    let n = count
        .checked_mul(ty.size() as u64)
        .filter(|&n| n <= MAX_PAYLOAD_BYTES)
        .ok_or_else(|| {
            Error::data(
                path,
                location,
                format!(
                    "{count} samples of {} bytes exceed the {} GiB limit pvrsim accepts",
                    ty.size(),
                    MAX_PAYLOAD_BYTES >> 30
                ),
            )
        })?;
    Ok(n)
}

/// Decompresses a gzip (possibly multi-member) or zlib stream `src` to
/// exactly `want` bytes. Refuses before decompressing if `want` is more
/// than deflate can produce from `src.len()` bytes; errors if the stream
/// ends early or is corrupt. Extra bytes after `want` are an error too
/// (the header and the data disagree).
pub fn inflate_exact(
    path: &Path,
    location: &str,
    src: &[u8],
    want: u64,
    zlib: bool,
) -> Result<Vec<u8>> {
    let max = (src.len() as u64).saturating_mul(MAX_DEFLATE_RATIO);
    if want > max {
        return Err(Error::data(
            path,
            location,
            format!(
                "the header needs {want} bytes of data but {} compressed bytes can hold at most {max}: the file is truncated or the header is wrong",
                src.len()
            ),
        ));
    }
    let mut out = Vec::new();
    let r: Box<dyn Read + '_> = if zlib {
        Box::new(flate2::read::ZlibDecoder::new(src))
    } else {
        Box::new(flate2::read::MultiGzDecoder::new(src))
    };
    let kind = if zlib { "zlib" } else { "gzip" };
    r.take(want + 1)
        .read_to_end(&mut out)
        .map_err(|e| Error::data(path, location, format!("{kind} data is corrupt: {e}")))?;
    if (out.len() as u64) < want {
        return Err(Error::data(
            path,
            location,
            format!(
                "data is truncated: the {kind} stream inflates to {} bytes, the header needs {want}",
                out.len()
            ),
        ));
    }
    if out.len() as u64 > want {
        return Err(Error::data(
            path,
            location,
            format!("the {kind} stream holds more than the {want} bytes the header describes: the header's sizes or type are wrong"),
        ));
    }
    Ok(out)
}

macro_rules! decode_vec {
    ($bytes:expr, $big:expr, $t:ty) => {{
        const N: usize = std::mem::size_of::<$t>();
        $bytes.chunks_exact(N).map(|c| {
            let mut a = [0u8; N];
            a.copy_from_slice(c);
            if $big {
                <$t>::from_be_bytes(a)
            } else {
                <$t>::from_le_bytes(a)
            }
        })
    }};
}

/// Decodes exactly `bytes.len() / ty.size()` samples (the caller checked
/// the length) into the compact storage described in the module docs.
/// Returns the voxels and whether the values were converted to f32 with
/// possible loss of precision.
pub fn decode_voxels(bytes: Vec<u8>, ty: NumType, big_endian: bool) -> (Voxels, bool) {
    let b = &bytes[..];
    match ty {
        NumType::U8 => (Voxels::U8(bytes), false),
        NumType::I8 => (
            Voxels::I16(b.iter().map(|&x| x as i8 as i16).collect()),
            false,
        ),
        NumType::U16 => (
            Voxels::U16(decode_vec!(b, big_endian, u16).collect()),
            false,
        ),
        NumType::I16 => (
            Voxels::I16(decode_vec!(b, big_endian, i16).collect()),
            false,
        ),
        NumType::F32 => (
            Voxels::F32(decode_vec!(b, big_endian, f32).collect()),
            false,
        ),
        NumType::I32 => (
            Voxels::F32(decode_vec!(b, big_endian, i32).map(|x| x as f32).collect()),
            true,
        ),
        NumType::U32 => (
            Voxels::F32(decode_vec!(b, big_endian, u32).map(|x| x as f32).collect()),
            true,
        ),
        NumType::I64 => (
            Voxels::F32(decode_vec!(b, big_endian, i64).map(|x| x as f32).collect()),
            true,
        ),
        NumType::U64 => (
            Voxels::F32(decode_vec!(b, big_endian, u64).map(|x| x as f32).collect()),
            true,
        ),
        NumType::F64 => (
            Voxels::F32(decode_vec!(b, big_endian, f64).map(|x| x as f32).collect()),
            true,
        ),
    }
}

/// Builds voxels from parsed text values (ASCII encodings), in the same
/// storage as [`decode_voxels`] would choose for `ty`. Values outside the
/// type's range are an error naming the sample.
pub fn voxels_from_f64(
    path: &Path,
    location: &str,
    values: &[f64],
    ty: NumType,
) -> Result<(Voxels, bool)> {
    let check = |lo: f64, hi: f64| -> Result<()> {
        if let Some(i) = values
            .iter()
            .position(|&v| !(v >= lo && v <= hi && v.fract() == 0.0))
        {
            return Err(Error::data(
                path,
                location,
                format!(
                    "sample {i}: {} is not a {} value",
                    values[i],
                    format!("{ty:?}").to_lowercase()
                ),
            ));
        }
        Ok(())
    };
    Ok(match ty {
        NumType::U8 => {
            check(0.0, 255.0)?;
            (Voxels::U8(values.iter().map(|&v| v as u8).collect()), false)
        }
        NumType::I8 => {
            check(-128.0, 127.0)?;
            (
                Voxels::I16(values.iter().map(|&v| v as i16).collect()),
                false,
            )
        }
        NumType::U16 => {
            check(0.0, 65535.0)?;
            (
                Voxels::U16(values.iter().map(|&v| v as u16).collect()),
                false,
            )
        }
        NumType::I16 => {
            check(-32768.0, 32767.0)?;
            (
                Voxels::I16(values.iter().map(|&v| v as i16).collect()),
                false,
            )
        }
        NumType::F32 => (
            Voxels::F32(values.iter().map(|&v| v as f32).collect()),
            false,
        ),
        _ => (
            Voxels::F32(values.iter().map(|&v| v as f32).collect()),
            true,
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_and_widens() {
        let (v, lossy) = decode_voxels(vec![0xff, 0x01], NumType::I8, false);
        assert_eq!((v, lossy), (Voxels::I16(vec![-1, 1]), false));
        let (v, _) = decode_voxels(vec![0x01, 0x02], NumType::U16, true);
        assert_eq!(v, Voxels::U16(vec![0x0102]));
        let (v, lossy) = decode_voxels(7i32.to_le_bytes().to_vec(), NumType::I32, false);
        assert_eq!((v, lossy), (Voxels::F32(vec![7.0]), true));
    }

    #[test]
    fn inflate_checks_both_ways() {
        use std::io::Write;
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(&[5u8; 100]).unwrap();
        let gz = e.finish().unwrap();
        let p = Path::new("x");
        assert_eq!(inflate_exact(p, "d", &gz, 100, false).unwrap().len(), 100);
        let e = inflate_exact(p, "d", &gz, 101, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("truncated"), "{e}");
        let e = inflate_exact(p, "d", &gz, 99, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("more than"), "{e}");
        let e = inflate_exact(p, "d", &gz, 1 << 40, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("at most"), "{e}");
        let e = inflate_exact(p, "d", &gz[..20], 100, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("gzip"), "{e}");
    }

    #[test]
    fn payload_overflow_is_an_error() {
        let e = payload_bytes(Path::new("f"), "sizes", u64::MAX / 2, NumType::F32);
        assert!(e.unwrap_err().to_string().contains("GiB"));
    }
}
