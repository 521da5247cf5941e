//! Reader for VTK XML image data (`.vti`, `<VTKFile type="ImageData">`),
//! sharing the `.vtu` machinery ([`vtu::scan`](crate::data::io::vtu)):
//! ascii, inline base64, appended raw/base64, zlib, UInt32/UInt64 headers,
//! either byte order.
//!
//! Placement: `<ImageData WholeExtent="x0 x1 y0 y1 z0 z1" Origin Spacing
//! Direction>`; sample `(i, j, k)` of the extent sits at
//! `Origin + Direction (i Spacing_x, j Spacing_y, k Spacing_z)` (VTK 9;
//! `Direction` is row-major and defaults to the identity), which must be
//! axis-aligned (see [`placement`](super::placement)). The grid is the
//! single `<Piece>`, whose `Extent` must equal `WholeExtent` (multi-piece
//! files are refused by name). The scalar is the `<PointData>` array named
//! `field`, or if `field` is empty the one `Scalars=` names, else the
//! first; it must have one component.

use std::path::Path;

use super::placement::{apply_flips, axis_aligned};
use super::samples::{decode_voxels, payload_bytes, voxels_from_f64};
use crate::data::io::read_bytes;
use crate::data::io::vtu::{get, scan, Format};
use crate::data::{volume::checked_count, Volume};
use crate::error::{Error, Result};

/// Reads a `.vti` file; `field` picks the point-data array (empty: the
/// active scalars, else the first array).
pub fn read(path: &Path, field: &str) -> Result<Volume> {
    let d = read_bytes(path)?;
    parse(&d, path, field)
}

fn numbers<const N: usize>(
    path: &Path,
    attrs: &[(String, String)],
    key: &str,
    default: Option<[f64; N]>,
) -> Result<[f64; N]> {
    let Some(v) = get(attrs, key) else {
        return default
            .ok_or_else(|| Error::data(path, "<ImageData>", format!("missing attribute {key}")));
    };
    let vals: Option<Vec<f64>> = v
        .split_ascii_whitespace()
        .map(|t| t.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect();
    vals.filter(|x| x.len() == N)
        .map(|x| std::array::from_fn(|i| x[i]))
        .ok_or_else(|| {
            Error::data(
                path,
                "<ImageData>",
                format!("{key}=\"{v}\" must be {N} finite numbers"),
            )
        })
}

fn extent(path: &Path, loc: &str, attrs: &[(String, String)], key: &str) -> Result<[i64; 6]> {
    let v = get(attrs, key)
        .ok_or_else(|| Error::data(path, loc, format!("missing attribute {key}")))?;
    let vals: Option<Vec<i64>> = v.split_ascii_whitespace().map(|t| t.parse().ok()).collect();
    match vals {
        Some(x) if x.len() == 6 && (0..3).all(|a| x[2 * a] <= x[2 * a + 1]) => {
            Ok(std::array::from_fn(|i| x[i]))
        }
        _ => Err(Error::data(
            path,
            loc,
            format!("{key}=\"{v}\" must be six integers x0 x1 y0 y1 z0 z1 with each min <= max"),
        )),
    }
}

/// Parses `.vti` bytes; `path` names the file in errors.
pub fn parse(d: &[u8], path: &Path, field: &str) -> Result<Volume> {
    let s = scan(d, path, "ImageData")?;
    let da = &s.dataset_attrs;
    if da.is_empty() {
        return Err(Error::data(path, "<ImageData>", "no <ImageData> element"));
    }
    let whole = extent(path, "<ImageData>", da, "WholeExtent")?;
    let origin = numbers::<3>(path, da, "Origin", Some([0.0; 3]))?;
    let spacing = numbers::<3>(path, da, "Spacing", Some([1.0; 3]))?;
    let dir = numbers::<9>(
        path,
        da,
        "Direction",
        Some([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
    )?;
    if s.pieces.len() != 1 {
        return Err(Error::data(
            path,
            "<ImageData>",
            format!(
                "{} <Piece> elements: multi-piece image data is not supported (merge the pieces, e.g. save from ParaView as one piece)",
                s.pieces.len()
            ),
        ));
    }
    let piece = &s.pieces[0];
    let pext = extent(path, "<Piece> 0", &piece.attrs, "Extent")?;
    if pext != whole {
        return Err(Error::data(
            path,
            "<Piece> 0",
            format!("Extent {pext:?} differs from WholeExtent {whole:?}: partial pieces are not supported"),
        ));
    }
    let span = |a: usize| (whole[2 * a + 1] - whole[2 * a]) as u64 + 1;
    let dims = [span(0), span(1), span(2)];
    let count = checked_count(dims).ok_or_else(|| {
        Error::data(
            path,
            "<ImageData> WholeExtent",
            format!("{dims:?} samples overflow 64 bits"),
        )
    })?;

    let arrays = &piece.point_data;
    let active = get(&piece.point_data_attrs, "Scalars");
    let a = if !field.is_empty() {
        arrays.iter().find(|a| a.name == field)
    } else {
        active
            .and_then(|n| arrays.iter().find(|a| a.name == n))
            .or_else(|| arrays.first())
    };
    let a = a.ok_or_else(|| {
        let names: Vec<String> = arrays.iter().map(|a| format!("\"{}\"", a.name)).collect();
        // A file cut inside its <DataArray> lists no array: say it is cut.
        let closing: &[u8] = b"</VTKFile>";
        if !d.windows(closing.len()).any(|w| w == closing) {
            let open_at = d
                .windows(b"<DataArray".len())
                .rposition(|w| w == b"<DataArray");
            return Error::data(
                path,
                match open_at {
                    Some(b) => format!("<DataArray> at byte {b}"),
                    None => format!("byte {}", d.len()),
                },
                format!(
                    "the file is truncated: it ends at byte {} before </VTKFile>{}",
                    d.len(),
                    if open_at.is_some() {
                        ", inside its last <DataArray>"
                    } else {
                        ""
                    }
                ),
            );
        }
        Error::data(
            path,
            "<PointData>",
            if field.is_empty() {
                "no point-data array: an image needs one scalar array".to_string()
            } else {
                format!(
                    "no array named \"{field}\"; the file has {}",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                )
            },
        )
    })?;
    if a.ncomp != 1 {
        return Err(s.ctx.err(
            a,
            format!(
                "has {} components: pvrsim renders scalar arrays (NumberOfComponents=\"1\")",
                a.ncomp
            ),
        ));
    }
    let nbytes = payload_bytes(path, &a.loc(), count, a.ty)?;
    let (mut voxels, lossy) = match a.format {
        Format::Ascii => {
            let v: Vec<f64> = s.ctx.ascii(a, "number")?;
            if v.len() as u64 != count {
                return Err(s.ctx.err(
                    a,
                    format!("has {} values, the extent needs {count}", v.len()),
                ));
            }
            voxels_from_f64(path, &a.loc(), &v, a.ty)?
        }
        _ => {
            let b = s.ctx.bytes(a)?;
            if b.len() as u64 != nbytes {
                return Err(s.ctx.err(
                    a,
                    format!(
                        "holds {} bytes, the extent {dims:?} of {:?} needs {nbytes}{}",
                        b.len(),
                        a.ty,
                        if (b.len() as u64) < nbytes {
                            " (truncated)"
                        } else {
                            ""
                        }
                    ),
                ));
            }
            decode_voxels(b.into_owned(), a.ty, s.ctx.big_endian)
        }
    };
    if lossy {
        tracing::warn!(
            "{}: {:?} samples of \"{}\" are stored as f32",
            path.display(),
            a.ty,
            a.name
        );
    }
    // d_a = column a of Direction times Spacing_a; the first sample sits
    // at Origin + Direction (extent_lo * Spacing).
    let col = |c: usize| [dir[c], dir[3 + c], dir[6 + c]];
    let dirs: [[f64; 3]; 3] = std::array::from_fn(|c| col(c).map(|x| x * spacing[c]));
    let first: [f64; 3] = std::array::from_fn(|r| {
        origin[r]
            + (0..3)
                .map(|c| dirs[c][r] * whole[2 * c] as f64)
                .sum::<f64>()
    });
    let p = axis_aligned(path, "<ImageData> Direction/Spacing", dims, dirs, first)?;
    apply_flips(&mut voxels, dims, &p);
    Volume::new(path, dims, p.spacing, p.origin, a.name.clone(), voxels)
}
