//! The NRRD header: fields, their types and lines, the type names, and
//! the placement (spacing and origin) they give.

use std::path::Path;

use super::super::placement::{axis_aligned, Placement};
use super::loc;
use crate::data::io::numeric::NumType;
use crate::error::{Error, Result};

/// How the samples are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Encoding {
    Raw,
    Gzip,
    Ascii,
    Hex,
}

/// The parsed header: every field pvrsim uses, with the line it came from.
#[derive(Debug, Default)]
pub(super) struct Header {
    pub(super) ty: Option<(NumType, usize)>,
    pub(super) dimension: Option<(usize, usize)>,
    pub(super) sizes: Option<(Vec<u64>, usize)>,
    pub(super) encoding: Option<(Encoding, usize)>,
    pub(super) big_endian: Option<bool>,
    pub(super) spacings: Option<(Vec<f64>, usize)>,
    pub(super) axis_mins: Option<(Vec<f64>, usize)>,
    pub(super) cell_centered: Vec<bool>,
    pub(super) directions: Option<(Vec<[f64; 3]>, usize)>,
    pub(super) space_origin: Option<([f64; 3], usize)>,
    pub(super) data_file: Option<(String, usize)>,
    pub(super) line_skip: usize,
    pub(super) byte_skip: i64,
    pub(super) content: Option<String>,
    /// Byte offset of the data in an attached file.
    pub(super) data_start: usize,
}

/// The NRRD type names (teem's `airEnumStr` for `nrrdType`, with aliases).
pub(super) fn parse_type(s: &str) -> Option<NumType> {
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

pub(super) fn parse_header(file: &[u8], path: &Path) -> Result<Header> {
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

pub(super) fn placement(
    h: &Header,
    path: &Path,
    dims: [u64; 3],
    dimension: usize,
) -> Result<Placement> {
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
