//! Reader for VTK XML unstructured grids (`.vtu`, `<VTKFile type="UnstructuredGrid">`).
//!
//! Supported, in any combination (this covers what ParaView, VTK and meshio write):
//! - `<DataArray format="ascii">`, `format="binary"` (inline base64) and
//!   `format="appended"` with `<AppendedData encoding="raw">` (data after the
//!   `_` marker, arrays located by their `offset`) or `encoding="base64"`;
//! - `header_type="UInt32"` (the default) or `"UInt64"` length headers;
//! - `compressor="vtkZLibDataCompressor"` (block header `nblocks, blocksize,
//!   lastblocksize, compressed sizes...`) or no compression;
//! - `byte_order="LittleEndian"` or `"BigEndian"`;
//! - `Points`, `Cells` (`connectivity`, `offsets`, `types`) and `PointData`
//!   arrays of type Int8..Int64, UInt8..UInt64, Float32, Float64 with any
//!   `NumberOfComponents`; several `Piece`s are concatenated.
//!
//! `CellData`, `FieldData` and string arrays are skipped. Cells other than
//! tetrahedra are handled as described in [`decompose`](super::decompose).
//!
//! Not supported (an error naming the element): other dataset types,
//! the LZ4 and LZMA compressors, polyhedron cells (`faces`/`faceoffsets`).
//!
//! Errors name the XML element (`<DataArray Name="speed">` in `<PointData>`)
//! or, for XML syntax errors, the byte offset.

use std::path::Path;

mod assemble;
mod decode;
pub mod vertices;

use assemble::assemble;

use super::decompose::{vtk_type_name, CellShape, TetBuilder};
use super::mapped::FileBytes;
use super::numeric::NumType;
use crate::data::{Field, TetMesh};
use crate::error::{Error, Result};

/// Reads a VTK XML unstructured grid from `path`.
pub fn read(path: &Path) -> Result<TetMesh> {
    let data = FileBytes::open(path)?;
    let mut s = scan(&data, path, "UnstructuredGrid")?;
    s.ctx.file = Some(&data);
    assemble(&s.ctx, s.pieces)
}

/// Point-data arrays as a piece declares them: name, type, components.
pub(crate) type Declared = Vec<(String, NumType, usize)>;

/// Reads a `.vtu` like [`read`], with the points' type and the point-data
/// arrays its first `<Piece>` declares (to check that the pieces of a
/// `.pvtu` agree), decoding only the point-data array `keep` when one is
/// named (the others are declared, and checked, but not read).
pub(crate) fn read_declared_keeping(
    path: &Path,
    keep: Option<&str>,
) -> Result<(TetMesh, Option<NumType>, Declared)> {
    let data = FileBytes::open(path)?;
    let mut s = scan(&data, path, "UnstructuredGrid")?;
    s.ctx.file = Some(&data);
    let (points, decl) = declared(&s.pieces);
    if let Some(keep) = keep {
        for p in &mut s.pieces {
            p.point_data.retain(|a| a.name == keep);
        }
    }
    Ok((assemble(&s.ctx, s.pieces)?, points, decl))
}

/// The points' type and the point-data arrays the first of `pieces`
/// declares.
fn declared(pieces: &[PieceDesc]) -> (Option<NumType>, Declared) {
    let first = pieces.first();
    let points = first.and_then(|p| p.points.as_ref()).map(|a| a.ty);
    let decl = first.map_or(Vec::new(), |p| {
        p.point_data
            .iter()
            .map(|a| (a.name.clone(), a.ty, a.ncomp))
            .collect()
    });
    (points, decl)
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Format {
    Ascii,
    Binary,
    Appended,
}

/// One `<DataArray>` as declared, with its inline text.
#[derive(Debug, Clone)]
pub(crate) struct ArrayDesc {
    pub(crate) name: String,
    parent: String,
    pub(crate) ty: NumType,
    pub(crate) ncomp: usize,
    pub(crate) format: Format,
    offset: usize,
    text: Vec<u8>,
}

impl ArrayDesc {
    pub(crate) fn loc(&self) -> String {
        format!("<DataArray Name=\"{}\"> in <{}>", self.name, self.parent)
    }
}

#[derive(Debug, Default)]
pub(crate) struct PieceDesc {
    /// The `<Piece>` element's attributes (kept for non-mesh kinds).
    pub(crate) attrs: Vec<(String, String)>,
    /// The `<PointData>` element's attributes (`Scalars=` names the active array).
    pub(crate) point_data_attrs: Vec<(String, String)>,
    npoints: usize,
    ncells: usize,
    points: Option<ArrayDesc>,
    conn: Option<ArrayDesc>,
    offsets: Option<ArrayDesc>,
    types: Option<ArrayDesc>,
    pub(crate) point_data: Vec<ArrayDesc>,
}

pub(crate) struct Ctx<'a> {
    path: &'a Path,
    pub(crate) big_endian: bool,
    header_u64: bool,
    zlib: bool,
    /// The bytes after the `_` of `<AppendedData>`, and whether they are base64.
    appended: Option<(&'a [u8], bool)>,
    /// Sorted offsets of all appended arrays, to delimit base64 runs.
    appended_offsets: Vec<usize>,
    /// The mapped file the bytes are, whose pages an array decoded gives
    /// back ([`Ctx::release`]); `None` for bytes given in memory.
    file: Option<&'a FileBytes>,
}

impl Ctx<'_> {
    /// Gives back the file's pages under appended array `a`, decoded: the
    /// file's bytes and the arrays made of them are then not all resident
    /// at once (a 2.5 M-tet piece with three fields: 155,580 -> 114,036 kB
    /// at the peak of `pvrsim info`). Reading
    /// `a` again re-reads the file. Nothing for arrays in the XML or bytes
    /// not mapped.
    pub(crate) fn release(&self, a: &ArrayDesc) {
        let (Some(file), Some((body, _)), Format::Appended) = (self.file, self.appended, a.format)
        else {
            return;
        };
        let end = self.appended_end(a.offset, body.len());
        let at = (body.as_ptr() as usize).wrapping_sub(file.as_ptr() as usize);
        if at <= file.len() && a.offset <= end {
            file.release(at + a.offset, at + end);
        }
    }

    /// Where the appended array at `offset` ends: at the next array's
    /// offset, or at the end of the `len` appended bytes.
    pub(crate) fn appended_end(&self, offset: usize, len: usize) -> usize {
        self.appended_offsets
            .iter()
            .copied()
            .find(|&o| o > offset)
            .unwrap_or(len)
            .min(len)
    }
}

fn attr_map(e: &quick_xml::events::BytesStart) -> Vec<(String, String)> {
    e.attributes()
        .flatten()
        .map(|a| {
            (
                String::from_utf8_lossy(a.key.local_name().as_ref()).into_owned(),
                String::from_utf8_lossy(&a.value).into_owned(),
            )
        })
        .collect()
}

pub(crate) fn get<'v>(attrs: &'v [(String, String)], key: &str) -> Option<&'v str> {
    attrs
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_str())
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// Parses the bytes of a `.vtu` file; `path` is only used in errors.
pub fn parse(d: &[u8], path: &Path) -> Result<TetMesh> {
    let s = scan(d, path, "UnstructuredGrid")?;
    assemble(&s.ctx, s.pieces)
}

/// A VTK XML file's structure: the decoding context, the pieces with their
/// arrays (not yet decoded), and the attributes of the dataset element
/// (`<ImageData WholeExtent=... Origin=... Spacing=...>`).
pub(crate) struct Scanned<'a> {
    pub(crate) ctx: Ctx<'a>,
    pub(crate) pieces: Vec<PieceDesc>,
    pub(crate) dataset_attrs: Vec<(String, String)>,
}

/// Scans a VTK XML file of dataset type `kind` (`UnstructuredGrid`,
/// `ImageData`): checks the header attributes and collects the pieces and
/// their arrays. Pieces of an `UnstructuredGrid` need `NumberOfPoints` and
/// `NumberOfCells`; other kinds keep the piece's attributes in
/// [`PieceDesc::attrs`].
pub(crate) fn scan<'a>(d: &'a [u8], path: &'a Path, kind: &str) -> Result<Scanned<'a>> {
    let mesh = kind == "UnstructuredGrid";
    let mut dataset_attrs = Vec::new();
    // Raw appended data is not XML: parse the XML only up to its start tag.
    let app_tag = find(d, b"<AppendedData");
    let (xml, app_start) = match app_tag {
        Some(t) => {
            let gt = d[t..]
                .iter()
                .position(|&b| b == b'>')
                .map(|i| t + i)
                .ok_or_else(|| {
                    Error::data(path, format!("byte {t}"), "unterminated <AppendedData> tag")
                })?;
            let mut s = gt + 1;
            while s < d.len() && d[s].is_ascii_whitespace() {
                s += 1;
            }
            if d.get(s) != Some(&b'_') {
                return Err(Error::data(
                    path,
                    "<AppendedData>",
                    format!("expected the \"_\" marker before the appended data at byte {s}"),
                ));
            }
            (&d[..=gt], Some(s + 1))
        }
        None => (d, None),
    };

    let mut reader = quick_xml::Reader::from_reader(xml);
    reader.config_mut().trim_text(true);
    let mut stack: Vec<String> = Vec::new();
    let mut pieces: Vec<PieceDesc> = Vec::new();
    let mut current: Option<ArrayDesc> = None;
    let mut seen_vtkfile = false;
    let mut ctx = Ctx {
        path,
        big_endian: false,
        header_u64: false,
        zlib: false,
        appended: None,
        appended_offsets: Vec::new(),
        file: None,
    };
    let mut appended_base64 = false;

    loop {
        let pos = reader.buffer_position();
        let ev = reader.read_event().map_err(|e| {
            Error::data(
                path,
                format!("byte {pos}"),
                format!("XML syntax error: {e}"),
            )
        })?;
        use quick_xml::events::Event;
        let (e, empty) = match ev {
            Event::Eof => break,
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(_) => {
                if stack.pop().as_deref() == Some("DataArray") {
                    if let Some(a) = current.take() {
                        place(a, &stack, &mut pieces, path)?;
                    }
                }
                continue;
            }
            Event::Text(t) => {
                if let Some(a) = current.as_mut() {
                    a.text.extend_from_slice(&t);
                    a.text.push(b' ');
                }
                continue;
            }
            Event::CData(t) => {
                if let Some(a) = current.as_mut() {
                    a.text.extend_from_slice(&t);
                }
                continue;
            }
            _ => continue,
        };
        let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
        let attrs = attr_map(&e);
        match name.as_str() {
            "VTKFile" => {
                seen_vtkfile = true;
                let ty = get(&attrs, "type").unwrap_or("");
                if ty != kind {
                    let what = if mesh {
                        "UnstructuredGrid (.vtu) files as meshes"
                    } else {
                        "ImageData (.vti) files as volumes"
                    };
                    return Err(Error::data(
                        path,
                        "<VTKFile>",
                        format!("type=\"{ty}\" is not supported here: pvrsim reads {what}"),
                    ));
                }
                ctx.big_endian = match get(&attrs, "byte_order").unwrap_or("LittleEndian") {
                    "LittleEndian" => false,
                    "BigEndian" => true,
                    o => {
                        return Err(Error::data(
                            path,
                            "<VTKFile>",
                            format!("byte_order=\"{o}\" must be LittleEndian or BigEndian"),
                        ))
                    }
                };
                ctx.header_u64 = match get(&attrs, "header_type").unwrap_or("UInt32") {
                    "UInt32" => false,
                    "UInt64" => true,
                    o => {
                        return Err(Error::data(
                            path,
                            "<VTKFile>",
                            format!("header_type=\"{o}\" must be UInt32 or UInt64"),
                        ))
                    }
                };
                ctx.zlib = match get(&attrs, "compressor").unwrap_or("") {
                    "" => false,
                    "vtkZLibDataCompressor" => true,
                    o => return Err(Error::data(path, "<VTKFile>", format!("compressor=\"{o}\" is not supported (only vtkZLibDataCompressor; re-save without compression or with zlib)"))),
                };
            }
            k if k == kind => dataset_attrs = attrs.clone(),
            "PointData" => {
                if let Some(p) = pieces.last_mut() {
                    p.point_data_attrs = attrs.clone();
                }
            }
            "Piece" if !mesh => pieces.push(PieceDesc {
                attrs: attrs.clone(),
                ..Default::default()
            }),
            "Piece" => {
                let count = |k: &str| -> Result<usize> {
                    let v = get(&attrs, k).ok_or_else(|| {
                        Error::data(
                            path,
                            format!("<Piece> {}", pieces.len()),
                            format!("missing attribute {k}"),
                        )
                    })?;
                    v.trim().parse().map_err(|_| {
                        Error::data(
                            path,
                            format!("<Piece> {}", pieces.len()),
                            format!("{k}=\"{v}\" is not a non-negative integer"),
                        )
                    })
                };
                pieces.push(PieceDesc {
                    npoints: count("NumberOfPoints")?,
                    ncells: count("NumberOfCells")?,
                    ..Default::default()
                });
            }
            "DataArray" => {
                let parent = stack.last().cloned().unwrap_or_default();
                let aname = get(&attrs, "Name").unwrap_or("").to_string();
                let loc = format!("<DataArray Name=\"{aname}\"> in <{parent}>");
                let tyname = get(&attrs, "type").unwrap_or("");
                let ty = match NumType::from_vtk_xml(tyname) {
                    Some(t) => Some(t),
                    // String and bit arrays only matter where we read them.
                    None if matches!(parent.as_str(), "PointData" | "Points" | "Cells") => {
                        return Err(Error::data(path, loc, format!("type=\"{tyname}\" is not supported (Int8..Int64, UInt8..UInt64, Float32, Float64)")));
                    }
                    None => None,
                };
                let ncomp = match get(&attrs, "NumberOfComponents") {
                    None => 1,
                    Some(v) => v
                        .trim()
                        .parse::<usize>()
                        .ok()
                        .filter(|&n| n > 0)
                        .ok_or_else(|| {
                            Error::data(
                                path,
                                &loc,
                                format!("NumberOfComponents=\"{v}\" is not a positive integer"),
                            )
                        })?,
                };
                let format = match get(&attrs, "format").unwrap_or("ascii") {
                    "ascii" => Format::Ascii,
                    "binary" => Format::Binary,
                    "appended" => Format::Appended,
                    o => {
                        return Err(Error::data(
                            path,
                            loc,
                            format!("format=\"{o}\" must be ascii, binary or appended"),
                        ))
                    }
                };
                let offset = match (format, get(&attrs, "offset")) {
                    (Format::Appended, Some(v)) => v.trim().parse::<usize>().map_err(|_| {
                        Error::data(
                            path,
                            &loc,
                            format!("offset=\"{v}\" is not a non-negative integer"),
                        )
                    })?,
                    (Format::Appended, None) => {
                        return Err(Error::data(
                            path,
                            loc,
                            "format=\"appended\" needs an offset attribute",
                        ))
                    }
                    _ => 0,
                };
                if format == Format::Appended {
                    ctx.appended_offsets.push(offset);
                }
                if let Some(ty) = ty {
                    let a = ArrayDesc {
                        name: aname,
                        parent,
                        ty,
                        ncomp,
                        format,
                        offset,
                        text: Vec::new(),
                    };
                    if empty {
                        place(a, &stack, &mut pieces, path)?;
                    } else {
                        current = Some(a);
                    }
                }
            }
            "AppendedData" => {
                appended_base64 = match get(&attrs, "encoding").unwrap_or("raw") {
                    "raw" => false,
                    "base64" => true,
                    o => {
                        return Err(Error::data(
                            path,
                            "<AppendedData>",
                            format!("encoding=\"{o}\" must be raw or base64"),
                        ))
                    }
                };
            }
            _ => {}
        }
        if !empty {
            stack.push(name);
        }
    }
    if !seen_vtkfile {
        return Err(Error::data(
            path,
            "byte 0",
            "not a VTK XML file: no <VTKFile> element",
        ));
    }
    if let Some(s) = app_start {
        let rest = &d[s..];
        let body = if appended_base64 {
            &rest[..find(rest, b"</AppendedData>").unwrap_or(rest.len())]
        } else {
            rest
        };
        ctx.appended = Some((body, appended_base64));
    }
    ctx.appended_offsets.sort_unstable();
    ctx.appended_offsets.dedup();
    if pieces.is_empty() {
        return Err(Error::data(path, format!("<{kind}>"), "no <Piece> element"));
    }
    Ok(Scanned {
        ctx,
        pieces,
        dataset_attrs,
    })
}

/// Files a finished `<DataArray>` under its piece.
fn place(a: ArrayDesc, stack: &[String], pieces: &mut [PieceDesc], path: &Path) -> Result<()> {
    let Some(piece) = pieces.last_mut() else {
        return Ok(());
    };
    if !stack.iter().any(|s| s == "Piece") {
        return Ok(());
    }
    match a.parent.as_str() {
        "Points" => piece.points = Some(a),
        "Cells" => match a.name.as_str() {
            "connectivity" => piece.conn = Some(a),
            "offsets" => piece.offsets = Some(a),
            "types" => piece.types = Some(a),
            "faces" | "faceoffsets" => {
                return Err(Error::data(
                    path,
                    a.loc(),
                    "polyhedron cells are not supported",
                ))
            }
            _ => {}
        },
        "PointData" => piece.point_data.push(a),
        _ => {}
    }
    Ok(())
}
