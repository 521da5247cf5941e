//! Reader for NRRD (teem's "nearly raw raster data", format versions
//! `NRRD0001`..`NRRD0005`): attached `.nrrd` (header, blank line, data) and
//! detached `.nhdr` (header only; `data file:` names the data, relative to
//! the header's folder).
//!
//! Supported:
//! - `type`: every scalar type and its aliases (`uchar`, `uint8`,
//!   `unsigned short`, `float`, ...); storage as in
//!   [`samples`](super::samples) (i8 widens to i16; 32/64-bit integers and
//!   double become f32 with a warning); `block` is refused;
//! - `encoding`: `raw`, `gzip`/`gz`, `ascii`/`text`/`txt`, `hex`
//!   (`bzip2` is refused by name);
//! - `endian` (required for multi-byte raw, gzip and hex data);
//! - `dimension: 3` (or 2, read as one slice); `sizes`;
//! - placement: `space directions` (axis-aligned, negative entries flipped,
//!   see [`placement`](super::placement)) with `space origin`, or else
//!   `spacings` with `axis mins` (cell-centred axes shifted by half a
//!   spacing) — missing spacings are 1, a missing origin is 0;
//! - `line skip`, `byte skip` (`-1`: the data is at the end of a raw file;
//!   after decompression for gzip);
//! - `data file` naming one file (the `LIST` and format-string forms are
//!   refused by name);
//! - descriptive fields (`content`, `kinds`, `labels`, `units`, `space`,
//!   `centers`, `min`, `max`, ...) and `key:=value` pairs are accepted;
//!   a field outside the NRRD specification is an error naming its line.
//!
//! Every size is checked against the file before anything is allocated.

//!
//! `header.rs` parses the header into a `header::Header`; this file reads
//! and decodes the data it describes.

use std::path::{Path, PathBuf};

use super::placement::apply_flips;
use super::samples::{decode_voxels, inflate_exact, payload_bytes, voxels_from_f64};
use crate::data::io::numeric::NumType;
use crate::data::io::read_bytes;
use crate::data::{volume::checked_count, Volume};
use crate::error::{Error, Result};

mod header;

use header::{parse_header, placement, Encoding};

/// Reads a `.nrrd` or `.nhdr` file. `field` names the scalar in the
/// returned volume (NRRD holds one unnamed scalar; empty: the header's
/// `content`, else `intensity`).
pub fn read(path: &Path, field: &str) -> Result<Volume> {
    let file = read_bytes(path)?;
    parse(&file, path, field)
}

fn loc(line: usize, key: &str) -> String {
    format!("line {line} (`{key}`)")
}

/// Parses NRRD bytes; `path` names the file in errors and anchors
/// `data file`.
pub fn parse(file: &[u8], path: &Path, field: &str) -> Result<Volume> {
    let h = parse_header(file, path)?;
    let (ty, ty_line) =
        h.ty.ok_or_else(|| Error::data(path, "header", "the required field `type` is missing"))?;
    let (dimension, dim_line) = h
        .dimension
        .ok_or_else(|| Error::data(path, "header", "the required field `dimension` is missing"))?;
    let (sizes, sizes_line) = h
        .sizes
        .clone()
        .ok_or_else(|| Error::data(path, "header", "the required field `sizes` is missing"))?;
    let (encoding, enc_line) = h
        .encoding
        .ok_or_else(|| Error::data(path, "header", "the required field `encoding` is missing"))?;
    if !(dimension == 2 || dimension == 3) {
        return Err(Error::data(
            path,
            loc(dim_line, "dimension"),
            format!("dimension {dimension} is not supported: pvrsim reads scalar 3D grids (dimension 3, or 2 for one slice)"),
        ));
    }
    if sizes.len() != dimension {
        return Err(Error::data(
            path,
            loc(sizes_line, "sizes"),
            format!("{} sizes for dimension {dimension}", sizes.len()),
        ));
    }
    let dims = [sizes[0], sizes[1], sizes.get(2).copied().unwrap_or(1)];
    let count = checked_count(dims).ok_or_else(|| {
        Error::data(
            path,
            loc(sizes_line, "sizes"),
            format!("sizes {sizes:?}: each must be >= 1 and their product must fit in 64 bits"),
        )
    })?;
    let nbytes = payload_bytes(path, &loc(sizes_line, "sizes"), count, ty)?;
    if ty.size() > 1 && encoding != Encoding::Ascii && h.big_endian.is_none() {
        return Err(Error::data(
            path,
            loc(ty_line, "type"),
            format!(
                "the field `endian` (little or big) is required for {}-byte samples",
                ty.size()
            ),
        ));
    }
    let big = h.big_endian.unwrap_or(false);

    // The data: the rest of this file, or the detached file.
    let (data_path, data_owned);
    let data: &[u8] = match &h.data_file {
        Some((name, line)) => {
            data_path = resolve_data_file(path, name, *line)?;
            // At most what the header describes, from a regular file.
            use crate::data::io::bounded::{bound, read_limited, Stored, SLACK};
            let stored = match encoding {
                Encoding::Raw => Stored::Raw,
                Encoding::Gzip => Stored::Compressed,
                Encoding::Hex => Stored::Hex,
                Encoding::Ascii => Stored::Ascii,
            };
            let skip = if h.byte_skip >= 0 {
                h.byte_skip as u64
            } else {
                16 * SLACK
            };
            let limit = bound(nbytes, skip, stored, ty.size() as u64);
            data_owned = read_limited(&data_path, limit, path, &loc(*line, "data file"))?;
            &data_owned
        }
        None => {
            data_path = path.to_path_buf();
            if h.data_start >= file.len() && is_detached_name(path) {
                return Err(Error::data(
                    path,
                    "header",
                    "a detached header (.nhdr) needs a `data file` field",
                ));
            }
            &file[h.data_start.min(file.len())..]
        }
    };
    let dloc = if h.data_file.is_some() {
        "data".to_string()
    } else {
        format!("data (byte {})", h.data_start)
    };
    let data = skip_lines(data, h.line_skip).ok_or_else(|| {
        Error::data(
            &data_path,
            "data",
            format!(
                "`line skip: {}` skips past the end of the file",
                h.line_skip
            ),
        )
    })?;

    let (voxels, lossy) = match encoding {
        Encoding::Raw => {
            let skip = if h.byte_skip == -1 {
                (data.len() as u64).checked_sub(nbytes).ok_or_else(|| {
                    truncated(&data_path, &dloc, data.len() as u64, nbytes, &sizes, ty)
                })?
            } else {
                h.byte_skip as u64
            };
            let have = (data.len() as u64).saturating_sub(skip);
            if have < nbytes {
                return Err(truncated(&data_path, &dloc, have, nbytes, &sizes, ty));
            }
            if have > nbytes {
                tracing::warn!(
                    "{}: {} bytes after the {nbytes} bytes of samples are ignored",
                    data_path.display(),
                    have - nbytes
                );
            }
            let s = skip as usize;
            decode_voxels(data[s..s + nbytes as usize].to_vec(), ty, big)
        }
        Encoding::Gzip => {
            if h.byte_skip < 0 {
                return Err(Error::data(
                    path,
                    "`byte skip`",
                    "byte skip -1 is only defined for raw encoding",
                ));
            }
            let skip = h.byte_skip as u64;
            let mut raw = inflate_exact(&data_path, &dloc, data, skip + nbytes, false)?;
            raw.drain(..skip as usize);
            decode_voxels(raw, ty, big)
        }
        Encoding::Hex => {
            // Two hex digits per byte, whitespace anywhere.
            if (data.len() as u64) < nbytes.saturating_mul(2) {
                return Err(truncated(
                    &data_path,
                    &dloc,
                    data.len() as u64 / 2,
                    nbytes,
                    &sizes,
                    ty,
                ));
            }
            let raw =
                decode_hex(data, nbytes as usize).map_err(|m| Error::data(&data_path, &dloc, m))?;
            decode_voxels(raw, ty, big)
        }
        Encoding::Ascii => {
            // Each value takes at least one character and a separator.
            if (data.len() as u64) < count.saturating_mul(2).saturating_sub(1) {
                return Err(Error::data(
                    &data_path,
                    &dloc,
                    format!(
                        "data is truncated: {} bytes of text cannot hold the {count} samples the header's sizes {sizes:?} describe",
                        data.len()
                    ),
                ));
            }
            let values =
                parse_ascii(data, count as usize).map_err(|m| Error::data(&data_path, &dloc, m))?;
            voxels_from_f64(&data_path, &dloc, &values, ty)?
        }
    };
    if lossy {
        tracing::warn!(
            "{}: {:?} samples are stored as f32 (values beyond 2^24 lose precision)",
            path.display(),
            ty
        );
    }
    let _ = enc_line;

    let placement = placement(&h, path, dims, dimension)?;
    let mut voxels = voxels;
    apply_flips(&mut voxels, dims, &placement);
    let name = if !field.is_empty() {
        field.to_string()
    } else {
        h.content.clone().unwrap_or_else(|| "intensity".into())
    };
    Volume::new(
        path,
        dims,
        placement.spacing,
        placement.origin,
        name,
        voxels,
    )
}

fn is_detached_name(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("nhdr"))
}

fn truncated(p: &Path, l: &str, have: u64, need: u64, sizes: &[u64], ty: NumType) -> Error {
    Error::data(
        p,
        l,
        format!(
            "data is truncated: {have} bytes present, sizes {sizes:?} of {:?} need {need}",
            ty
        ),
    )
}

fn resolve_data_file(path: &Path, name: &str, line: usize) -> Result<PathBuf> {
    let name = name.trim();
    let first = name.split_ascii_whitespace().next().unwrap_or("");
    if first == "LIST" || name.split_ascii_whitespace().count() > 1 {
        return Err(Error::data(
            path,
            loc(line, "data file"),
            format!("\"{name}\": multi-file data (LIST or a format string) is not supported; concatenate the slices into one file"),
        ));
    }
    if name.is_empty() {
        return Err(Error::data(path, loc(line, "data file"), "empty file name"));
    }
    crate::data::io::bounded::resolve_under(path, name, &loc(line, "data file"))
}

fn skip_lines(d: &[u8], n: usize) -> Option<&[u8]> {
    let mut p = 0;
    for _ in 0..n {
        p += d[p..].iter().position(|&b| b == b'\n')? + 1;
    }
    Some(&d[p..])
}

fn decode_hex(d: &[u8], n: usize) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(n);
    let mut hi: Option<u8> = None;
    for (i, &c) in d.iter().enumerate() {
        if c.is_ascii_whitespace() {
            continue;
        }
        let v = (c as char)
            .to_digit(16)
            .ok_or_else(|| format!("byte {i}: {:?} is not a hex digit", c as char))?
            as u8;
        match hi.take() {
            None => hi = Some(v),
            Some(h) => {
                out.push(h << 4 | v);
                if out.len() == n {
                    return Ok(out);
                }
            }
        }
    }
    Err(format!(
        "data is truncated: {} bytes of hex data, {n} needed",
        out.len()
    ))
}

fn parse_ascii(d: &[u8], n: usize) -> Result<Vec<f64>, String> {
    let text = std::str::from_utf8(d).map_err(|e| format!("ascii data is not text: {e}"))?;
    let mut out = Vec::with_capacity(n);
    for (i, t) in text
        .split(|c: char| c.is_ascii_whitespace() || c == ',')
        .filter(|t| !t.is_empty())
        .enumerate()
    {
        if i == n {
            return Err(format!(
                "more than the {n} values the header's sizes describe"
            ));
        }
        let v: f64 = t.parse().map_err(|_| {
            format!(
                "value {i}: \"{}\" is not a number",
                t.chars().take(40).collect::<String>()
            )
        })?;
        out.push(v);
    }
    if out.len() < n {
        return Err(format!(
            "data is truncated: {} values, the header's sizes describe {n}",
            out.len()
        ));
    }
    Ok(out)
}
#[cfg(test)]
mod tests {
    use super::*;

    fn hdr(body: &str) -> Vec<u8> {
        format!("NRRD0004\n{body}\n\n").into_bytes()
    }

    #[test]
    fn attached_raw_u16_big_endian_with_flip() {
        let mut f = hdr("type: ushort\ndimension: 3\nsizes: 2 1 1\nendian: big\nencoding: raw\nspace directions: (-2,0,0) (0,1,0) (0,0,1)\nspace origin: (4,5,6)");
        f.extend_from_slice(&[0, 1, 0, 2]);
        let v = parse(&f, Path::new("a.nrrd"), "").unwrap();
        assert_eq!(v.dims, [2, 1, 1]);
        assert_eq!(v.spacing, [2.0, 1.0, 1.0]);
        assert_eq!(v.origin, [2.0, 5.0, 6.0]);
        assert_eq!(v.voxels, crate::data::Voxels::U16(vec![2, 1]));
        assert_eq!(v.field, "intensity");
    }

    #[test]
    fn ascii_and_hex() {
        let mut f = hdr("type: int8\ndimension: 3\nsizes: 3 1 1\nencoding: ascii\nspacings: 0.5 1 1\naxis mins: 1 2 3");
        f.extend_from_slice(b"-1 0 7\n");
        let v = parse(&f, Path::new("a.nrrd"), "s").unwrap();
        assert_eq!(v.voxels, crate::data::Voxels::I16(vec![-1, 0, 7]));
        assert_eq!((v.spacing, v.origin), ([0.5, 1.0, 1.0], [1.0, 2.0, 3.0]));
        let mut f = hdr("type: uint8\ndimension: 2\nsizes: 2 1\nencoding: hex");
        f.extend_from_slice(b"0a ff\n");
        let v = parse(&f, Path::new("a.nrrd"), "").unwrap();
        assert_eq!(v.voxels, crate::data::Voxels::U8(vec![10, 255]));
    }
}
