//! Reader for AVS field files (`.fld`) holding a uniform scalar grid.
//!
//! The file is a text header of `key = value` lines (`#` starts a comment;
//! the first line is conventionally `# AVS field file`), ended by two
//! form-feed characters (`0x0C 0x0C`) after which the samples follow in
//! binary, x fastest. Required: `ndim = 3` (or 2), `dim1..dimN`,
//! `veclen = 1`, `data` (`byte`, `short`, `integer`, `float`, `double`, or
//! the `xdr_` forms), `field = uniform`. Optional: `nspace` (must equal
//! `ndim`), `min_ext`/`max_ext` (world extents of the first and last
//! sample: spacing `(max - min) / (dim - 1)`; without them spacing 1 at
//! origin 0), `label`, `unit`, `min_val`, `max_val` (descriptive).
//!
//! Byte order: AVS writes binary data high byte first (XDR), so
//! multi-byte samples are read big-endian.
//!
//! External data (`variable 1 file=NAME filetype=binary skip=N`, the name
//! relative to the header's folder) replaces the embedded samples; other
//! `filetype`s, `offset`/`stride` and `coord` lines are refused by name.

use std::path::Path;

use super::placement::axis_aligned;
use super::samples::{decode_voxels, payload_bytes};
use crate::data::io::numeric::NumType;
use crate::data::io::read_bytes;
use crate::data::{volume::checked_count, Volume};
use crate::error::{Error, Result};

/// Reads a `.fld` file; `field` names the scalar (empty: the header's
/// `label`, else `intensity`).
pub fn read(path: &Path, field: &str) -> Result<Volume> {
    let d = read_bytes(path)?;
    parse(&d, path, field)
}

#[derive(Default)]
struct Header {
    ndim: Option<u64>,
    dims: [Option<u64>; 3],
    veclen: Option<u64>,
    ty: Option<NumType>,
    field_seen: bool,
    min_ext: Option<Vec<f64>>,
    max_ext: Option<Vec<f64>>,
    label: Option<String>,
    /// The `variable` line's text after the keyword, and its line.
    external: Option<(String, usize)>,
}

/// Parses AVS field bytes; `path` names the file in errors and anchors an
/// external data file.
pub fn parse(d: &[u8], path: &Path, field: &str) -> Result<Volume> {
    let ff = d.windows(2).position(|w| w == b"\x0c\x0c");
    let head_end = ff.unwrap_or(d.len());
    let text = std::str::from_utf8(&d[..head_end]).map_err(|e| {
        Error::data(
            path,
            format!("byte {}", e.valid_up_to()),
            "the header is not text (an AVS field header is text ended by two form feeds)",
        )
    })?;
    if !text.trim_start().starts_with('#') && !text.contains("ndim") {
        return Err(Error::data(
            path,
            "line 1",
            "not an AVS field file (no `# AVS` comment and no ndim)",
        ));
    }
    let mut h = Header::default();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let l = |k: &str| format!("line {line_no} (`{k}`)");
        if let Some(rest) = line.strip_prefix("variable") {
            h.external = Some((rest.to_string(), line_no));
            continue;
        }
        if line.starts_with("coord") {
            return Err(Error::data(
                path,
                l("coord"),
                "coordinate files are not supported (only uniform fields with min_ext/max_ext)",
            ));
        }
        let (k, v) = line.split_once('=').ok_or_else(|| {
            Error::data(
                path,
                format!("line {line_no}"),
                format!(
                    "\"{}\" is not a `key = value` line",
                    line.chars().take(60).collect::<String>()
                ),
            )
        })?;
        let (k, v) = (k.trim(), v.trim());
        let int = |what: &str| -> Result<u64> {
            v.parse::<u64>().ok().filter(|&n| n >= 1).ok_or_else(|| {
                Error::data(path, l(what), format!("\"{v}\" is not a positive integer"))
            })
        };
        let floats = |what: &str| -> Result<Vec<f64>> {
            v.split_ascii_whitespace()
                .map(|t| t.parse::<f64>().ok().filter(|x| x.is_finite()))
                .collect::<Option<Vec<_>>>()
                .ok_or_else(|| Error::data(path, l(what), format!("\"{v}\" must be numbers")))
        };
        match k {
            "ndim" => h.ndim = Some(int(k)?),
            "dim1" => h.dims[0] = Some(int(k)?),
            "dim2" => h.dims[1] = Some(int(k)?),
            "dim3" => h.dims[2] = Some(int(k)?),
            "nspace" => {
                let n = int(k)?;
                if Some(n) != h.ndim && h.ndim.is_some() {
                    return Err(Error::data(
                        path,
                        l(k),
                        format!("nspace {n} differs from ndim: only uniform grids are supported"),
                    ));
                }
            }
            "veclen" => h.veclen = Some(int(k)?),
            "data" => {
                h.ty = Some(match v.trim_start_matches("xdr_") {
                    "byte" => NumType::U8,
                    "short" => NumType::I16,
                    "integer" | "int" => NumType::I32,
                    "float" => NumType::F32,
                    "double" => NumType::F64,
                    o => {
                        return Err(Error::data(
                            path,
                            l(k),
                            format!(
                        "data type \"{o}\" is not supported (byte, short, integer, float, double)"
                    ),
                        ))
                    }
                })
            }
            "field" => {
                h.field_seen = true;
                if v != "uniform" {
                    return Err(Error::data(
                        path,
                        l(k),
                        format!("field type \"{v}\" is not supported: pvrsim reads uniform fields"),
                    ));
                }
            }
            "min_ext" => h.min_ext = Some(floats(k)?),
            "max_ext" => h.max_ext = Some(floats(k)?),
            "label" => h.label = Some(v.split_ascii_whitespace().next().unwrap_or(v).to_string()),
            "unit" | "min_val" | "max_val" => {}
            o => {
                return Err(Error::data(
                    path,
                    format!("line {line_no}"),
                    format!("unknown AVS field keyword \"{o}\""),
                ))
            }
        }
    }
    let missing = |k: &str| {
        Error::data(
            path,
            "header",
            format!("the required keyword `{k}` is missing"),
        )
    };
    let ndim = h.ndim.ok_or_else(|| missing("ndim"))?;
    if !(ndim == 2 || ndim == 3) {
        return Err(Error::data(
            path,
            "header (`ndim`)",
            format!("ndim {ndim}: pvrsim reads 3D grids (or 2D, as one slice)"),
        ));
    }
    let mut dims = [1u64; 3];
    for (a, (d, given)) in dims.iter_mut().zip(h.dims).enumerate().take(ndim as usize) {
        *d = given.ok_or_else(|| missing(&format!("dim{}", a + 1)))?;
    }
    if h.veclen.ok_or_else(|| missing("veclen"))? != 1 {
        return Err(Error::data(
            path,
            "header (`veclen`)",
            "veclen must be 1: pvrsim renders scalar fields",
        ));
    }
    let ty = h.ty.ok_or_else(|| missing("data"))?;
    if !h.field_seen {
        return Err(missing("field"));
    }
    let count = checked_count(dims).ok_or_else(|| {
        Error::data(
            path,
            "header (`dim`)",
            format!("{dims:?} samples overflow 64 bits"),
        )
    })?;
    let nbytes = payload_bytes(path, "header (`dim`)", count, ty)?;

    let ext_data;
    let (data, dpath, dloc): (&[u8], std::path::PathBuf, String) = match &h.external {
        Some((spec, line)) => {
            let (file, skip) = parse_variable(spec)
                .map_err(|m| Error::data(path, format!("line {line} (`variable`)"), m))?;
            use crate::data::io::bounded::{bound, read_limited, resolve_under, Stored};
            let l = format!("line {line} (`variable`)");
            let p = resolve_under(path, &file, &l)?;
            let limit = bound(nbytes, skip, Stored::Raw, 1);
            ext_data = read_limited(&p, limit, path, &l)?;
            let s = (skip as usize).min(ext_data.len());
            (&ext_data[s..], p, format!("data (after skip={skip})"))
        }
        None => {
            let start = ff.ok_or_else(|| {
                Error::data(
                    path,
                    "header",
                    "no data: the header must end with two form feeds (^L^L) followed by the samples",
                )
            })? + 2;
            (
                &d[start..],
                path.to_path_buf(),
                format!("data (byte {start})"),
            )
        }
    };
    if (data.len() as u64) < nbytes {
        return Err(Error::data(
            &dpath,
            dloc,
            format!(
                "data is truncated: {} bytes present, {dims:?} of {ty:?} need {nbytes}",
                data.len()
            ),
        ));
    }
    let (voxels, lossy) = decode_voxels(data[..nbytes as usize].to_vec(), ty, true);
    if lossy {
        tracing::warn!("{}: {ty:?} samples are stored as f32", path.display());
    }

    // min_ext/max_ext: world positions of the first and last samples.
    let (mut lo, mut hi) = ([0.0f64; 3], [0.0f64; 3]);
    for a in 0..3 {
        hi[a] = (dims[a] - 1) as f64;
    }
    if let (Some(mn), Some(mx)) = (&h.min_ext, &h.max_ext) {
        if mn.len() < ndim as usize || mx.len() < ndim as usize {
            return Err(Error::data(
                path,
                "header (`min_ext`/`max_ext`)",
                format!("need {ndim} values each"),
            ));
        }
        let n = ndim as usize;
        lo[..n].copy_from_slice(&mn[..n]);
        hi[..n].copy_from_slice(&mx[..n]);
    }
    let dirs: [[f64; 3]; 3] = std::array::from_fn(|a| {
        let mut d = [0.0; 3];
        d[a] = if dims[a] > 1 {
            (hi[a] - lo[a]) / (dims[a] - 1) as f64
        } else {
            1.0
        };
        d
    });
    let p = axis_aligned(path, "header (`min_ext`/`max_ext`)", dims, dirs, lo)?;
    let mut voxels = voxels;
    super::placement::apply_flips(&mut voxels, dims, &p);
    let name = if !field.is_empty() {
        field.to_string()
    } else {
        h.label.unwrap_or_else(|| "intensity".into())
    };
    Volume::new(path, dims, p.spacing, p.origin, name, voxels)
}

/// `variable 1 file=NAME filetype=binary skip=N` -> (NAME, N).
fn parse_variable(spec: &str) -> std::result::Result<(String, u64), String> {
    let mut toks = spec.split_ascii_whitespace();
    if toks.next() != Some("1") {
        return Err("only `variable 1` (one scalar) is supported".into());
    }
    let (mut file, mut skip, mut binary) = (None, 0u64, false);
    for t in toks {
        let (k, v) = t
            .split_once('=')
            .ok_or_else(|| format!("\"{t}\" is not key=value"))?;
        match k {
            "file" => file = Some(v.to_string()),
            "filetype" => {
                binary = v == "binary";
                if !binary {
                    return Err(format!("filetype={v} is not supported (binary only)"));
                }
            }
            "skip" => {
                skip = v
                    .parse()
                    .map_err(|_| format!("skip={v} is not an integer"))?
            }
            "offset" | "stride" if v == "0" || (k == "stride" && v == "1") => {}
            o => return Err(format!("{o}={v} is not supported")),
        }
    }
    if !binary {
        return Err("filetype=binary is required".into());
    }
    Ok((file.ok_or("file= is missing")?, skip))
}
