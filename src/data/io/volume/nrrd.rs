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

use std::path::{Path, PathBuf};

use super::placement::{apply_flips, axis_aligned};
use super::samples::{decode_voxels, inflate_exact, payload_bytes, voxels_from_f64};
use crate::data::io::numeric::NumType;
use crate::data::io::read_bytes;
use crate::data::{volume::checked_count, Volume};
use crate::error::{Error, Result};

/// How the samples are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Raw,
    Gzip,
    Ascii,
    Hex,
}

/// The parsed header: every field pvrsim uses, with the line it came from.
#[derive(Debug, Default)]
struct Header {
    ty: Option<(NumType, usize)>,
    dimension: Option<(usize, usize)>,
    sizes: Option<(Vec<u64>, usize)>,
    encoding: Option<(Encoding, usize)>,
    big_endian: Option<bool>,
    spacings: Option<(Vec<f64>, usize)>,
    axis_mins: Option<(Vec<f64>, usize)>,
    cell_centered: Vec<bool>,
    directions: Option<(Vec<[f64; 3]>, usize)>,
    space_origin: Option<([f64; 3], usize)>,
    data_file: Option<(String, usize)>,
    line_skip: usize,
    byte_skip: i64,
    content: Option<String>,
    /// Byte offset of the data in an attached file.
    data_start: usize,
}

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
            let base = path.parent().unwrap_or(Path::new(""));
            data_path = resolve_data_file(path, base, name, *line)?;
            data_owned = std::fs::read(&data_path).map_err(|e| {
                Error::data(
                    path,
                    loc(*line, "data file"),
                    format!("cannot read {}: {e}", data_path.display()),
                )
            })?;
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

fn resolve_data_file(path: &Path, base: &Path, name: &str, line: usize) -> Result<PathBuf> {
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
    Ok(base.join(name))
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

/// The NRRD type names (teem's `airEnumStr` for `nrrdType`, with aliases).
fn parse_type(s: &str) -> Option<NumType> {
    let s = s.trim().to_ascii_lowercase();
    Some(match s.as_str() {
        "signed char" | "int8" | "int8_t" => NumType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => NumType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            NumType::I16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => NumType::U16,
        "int" | "signed int" | "int32" | "int32_t" => NumType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => NumType::U32,
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => NumType::I64,
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            NumType::U64
        }
        "float" => NumType::F32,
        "double" => NumType::F64,
        _ => return None,
    })
}

/// Fields of the NRRD specification that do not change how pvrsim reads
/// the samples (descriptive, or per-axis metadata).
const DESCRIPTIVE: &[&str] = &[
    "content",
    "kinds",
    "labels",
    "units",
    "space units",
    "space",
    "space dimension",
    "measurement frame",
    "min",
    "max",
    "old min",
    "oldmin",
    "old max",
    "oldmax",
    "axis maxs",
    "axismaxs",
    "thicknesses",
    "sample units",
    "sampleunits",
    "number",
    "block size",
    "blocksize",
];

fn parse_header(file: &[u8], path: &Path) -> Result<Header> {
    if !file.starts_with(b"NRRD000") || file.len() < 8 || !(b'1'..=b'9').contains(&file[7]) {
        return Err(Error::data(
            path,
            "line 1",
            "not a NRRD file (the first line must be the magic NRRD0001..NRRD0005)",
        ));
    }
    let mut h = Header::default();
    let mut p = 0usize;
    let mut line_no = 0usize;
    loop {
        if p >= file.len() {
            h.data_start = file.len();
            break;
        }
        let end = file[p..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(file.len(), |i| p + i);
        line_no += 1;
        let raw = &file[p..end];
        p = (end + 1).min(file.len().max(end + 1));
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        if raw.is_empty() {
            h.data_start = p.min(file.len());
            break;
        }
        if line_no == 1 {
            continue; // magic
        }
        let line = std::str::from_utf8(raw).map_err(|_| {
            Error::data(
                path,
                format!("line {line_no}"),
                "header line is not text (a missing blank line before the data?)",
            )
        })?;
        if line.starts_with('#') {
            continue;
        }
        if line.contains(":=") {
            continue; // key/value pair: free-form metadata
        }
        let (key, value) = line.split_once(": ").ok_or_else(|| {
            Error::data(
                path,
                format!("line {line_no}"),
                format!(
                    "\"{}\" is not a `field: value` line",
                    line.chars().take(60).collect::<String>()
                ),
            )
        })?;
        let key = key.trim().to_ascii_lowercase();
        let value = value.trim();
        let l = loc(line_no, &key);
        let err = |m: String| Error::data(path, l.clone(), m);
        match key.as_str() {
            "type" => {
                let t = parse_type(value).ok_or_else(|| {
                    err(format!(
                        "\"{value}\" is not a supported sample type (int8..uint64, float, double; not block)"
                    ))
                })?;
                h.ty = Some((t, line_no));
            }
            "dimension" => {
                let d = value
                    .parse::<usize>()
                    .map_err(|_| err(format!("\"{value}\" is not a positive integer")))?;
                h.dimension = Some((d, line_no));
            }
            "sizes" => {
                let v = value
                    .split_ascii_whitespace()
                    .map(|t| t.parse::<u64>().ok().filter(|&n| n >= 1))
                    .collect::<Option<Vec<_>>>()
                    .ok_or_else(|| {
                        err(format!(
                            "\"{value}\" must be positive integers, one per axis"
                        ))
                    })?;
                h.sizes = Some((v, line_no));
            }
            "encoding" => {
                let e = match value.to_ascii_lowercase().as_str() {
                    "raw" => Encoding::Raw,
                    "gzip" | "gz" => Encoding::Gzip,
                    "ascii" | "text" | "txt" => Encoding::Ascii,
                    "hex" => Encoding::Hex,
                    "bzip2" | "bz2" => {
                        return Err(err(
                            "bzip2 encoding is not supported (re-save as raw or gzip, e.g. `unu save -e gzip`)".into(),
                        ))
                    }
                    o => {
                        return Err(err(format!(
                            "unknown encoding \"{o}\" (raw, gzip, ascii, hex)"
                        )))
                    }
                };
                h.encoding = Some((e, line_no));
            }
            "endian" => {
                h.big_endian = Some(match value.to_ascii_lowercase().as_str() {
                    "little" => false,
                    "big" => true,
                    o => return Err(err(format!("\"{o}\" must be little or big"))),
                });
            }
            "spacings" => {
                let v = parse_floats(value, true).ok_or_else(|| {
                    err(format!("\"{value}\" must be numbers (or nan), one per axis"))
                })?;
                h.spacings = Some((v, line_no));
            }
            "axis mins" | "axismins" => {
                let v = parse_floats(value, true).ok_or_else(|| {
                    err(format!("\"{value}\" must be numbers (or nan), one per axis"))
                })?;
                h.axis_mins = Some((v, line_no));
            }
            "centers" | "centerings" => {
                h.cell_centered = value
                    .split_ascii_whitespace()
                    .map(|t| t.eq_ignore_ascii_case("cell"))
                    .collect();
            }
            "space directions" => {
                let v = parse_vectors(value).map_err(err)?;
                h.directions = Some((v, line_no));
            }
            "space origin" => {
                let v = parse_vectors(value).map_err(err)?;
                if v.len() != 1 {
                    return Err(err(format!("\"{value}\" must be one vector (x,y,z)")));
                }
                h.space_origin = Some((v[0], line_no));
            }
            "data file" | "datafile" => h.data_file = Some((value.to_string(), line_no)),
            "line skip" | "lineskip" => {
                h.line_skip = value
                    .parse()
                    .map_err(|_| err(format!("\"{value}\" is not a non-negative integer")))?;
            }
            "byte skip" | "byteskip" => {
                h.byte_skip = value
                    .parse::<i64>()
                    .ok()
                    .filter(|&n| n >= -1)
                    .ok_or_else(|| err(format!("\"{value}\" must be -1 or a non-negative integer")))?;
            }
            k if DESCRIPTIVE.contains(&k) => {
                if k == "content" {
                    h.content = Some(value.to_string());
                }
            }
            k => {
                return Err(err(format!(
                    "unknown field \"{k}\" (not in the NRRD specification; metadata belongs in `key:=value` lines)"
                )))
            }
        }
    }
    Ok(h)
}

fn parse_floats(s: &str, allow_nan: bool) -> Option<Vec<f64>> {
    s.split_ascii_whitespace()
        .map(|t| {
            let v: f64 = t.parse().ok()?;
            (v.is_finite() || (allow_nan && v.is_nan())).then_some(v)
        })
        .collect()
}

/// Parses `(a,b,c) (d,e,f) none ...`; `none` becomes NaNs.
fn parse_vectors(s: &str) -> std::result::Result<Vec<[f64; 3]>, String> {
    let mut out = Vec::new();
    let mut rest = s.trim();
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("none") {
            out.push([f64::NAN; 3]);
            rest = r.trim_start();
            continue;
        }
        let body = rest
            .strip_prefix('(')
            .and_then(|r| r.split_once(')'))
            .ok_or_else(|| format!("\"{s}\" must be vectors like (1,0,0) or none"))?;
        let comps = body
            .0
            .split(',')
            .map(|t| t.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
            .collect::<Option<Vec<_>>>()
            .filter(|v| v.len() == 3)
            .ok_or_else(|| {
                format!(
                    "\"({})\" must be three finite numbers: pvrsim needs a 3D space",
                    body.0
                )
            })?;
        out.push([comps[0], comps[1], comps[2]]);
        rest = body.1.trim_start();
    }
    Ok(out)
}

fn placement(
    h: &Header,
    path: &Path,
    dims: [u64; 3],
    dimension: usize,
) -> Result<super::placement::Placement> {
    if let Some((dirs, line)) = &h.directions {
        let l = loc(*line, "space directions");
        if dirs.len() != dimension {
            return Err(Error::data(
                path,
                l,
                format!("{} vectors for dimension {dimension}", dirs.len()),
            ));
        }
        if dirs.iter().any(|d| d[0].is_nan()) {
            return Err(Error::data(
                path,
                l,
                "`none` for a spatial axis: pvrsim reads scalar grids whose every axis is spatial",
            ));
        }
        if h.spacings.is_some() {
            return Err(Error::data(
                path,
                l,
                "both `space directions` and `spacings` are given (the NRRD format allows only one)",
            ));
        }
        let d2 = dirs.get(2).copied().unwrap_or([0.0, 0.0, 1.0]);
        let origin = h.space_origin.map_or([0.0; 3], |(o, _)| o);
        return axis_aligned(path, &l, dims, [dirs[0], dirs[1], d2], origin);
    }
    let mut spacing = [1.0f64; 3];
    if let Some((s, line)) = &h.spacings {
        if s.len() != dimension {
            return Err(Error::data(
                path,
                loc(*line, "spacings"),
                format!("{} spacings for dimension {dimension}", s.len()),
            ));
        }
        for (a, &v) in s.iter().enumerate() {
            if !v.is_nan() {
                spacing[a] = v;
            }
        }
    }
    let mut origin = h.space_origin.map_or([0.0; 3], |(o, _)| o);
    if let (None, Some((m, line))) = (&h.space_origin, &h.axis_mins) {
        if m.len() != dimension {
            return Err(Error::data(
                path,
                loc(*line, "axis mins"),
                format!("{} values for dimension {dimension}", m.len()),
            ));
        }
        for (a, &v) in m.iter().enumerate() {
            if !v.is_nan() {
                let half = if h.cell_centered.get(a) == Some(&true) {
                    0.5 * spacing[a].abs()
                } else {
                    0.0
                };
                origin[a] = v + half;
            }
        }
    }
    let l = h
        .spacings
        .as_ref()
        .map_or("spacings".to_string(), |(_, line)| loc(*line, "spacings"));
    let dirs = [
        [spacing[0], 0.0, 0.0],
        [0.0, spacing[1], 0.0],
        [0.0, 0.0, spacing[2]],
    ];
    axis_aligned(path, &l, dims, dirs, origin)
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
