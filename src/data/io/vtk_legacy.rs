//! Reader for VTK legacy files (`.vtk`) holding an `UNSTRUCTURED_GRID`.
//!
//! Supported:
//! - `ASCII` and `BINARY` (big-endian, as the format prescribes) encodings,
//!   any `# vtk DataFile Version` (2.0 to 5.1);
//! - `POINTS n type` with any numeric type (float, double, int, ...);
//! - cells in the classic layout (`CELLS n size`, then `k i0 .. ik` per cell,
//!   32-bit integers) and in the version 5.1 layout that ParaView and VTK 9
//!   write (`CELLS n_offsets n_connectivity`, then `OFFSETS type` and
//!   `CONNECTIVITY type` arrays); `CELL_TYPES n`;
//! - `POINT_DATA n` with `SCALARS name type [ncomp]` (with or without a
//!   `LOOKUP_TABLE` line), `VECTORS`, `NORMALS`, `TENSORS`, `TENSORS6`,
//!   `TEXTURE_COORDINATES` and `FIELD name n` arrays, each becoming a
//!   [`Field`] (`%20` in names decoded);
//! - `CELL_DATA`, standalone `LOOKUP_TABLE`, `COLOR_SCALARS`, dataset-level
//!   `FIELD` data and `METADATA` blocks (`INFORMATION`, `COMPONENT_NAMES`)
//!   are parsed past and dropped.
//!
//! Cells other than tetrahedra are handled as described in
//! [`decompose`](super::decompose).
//!
//! Not supported (an error): other dataset types (`STRUCTURED_POINTS`,
//! `POLYDATA`, ...), `bit` and `string` arrays, polyhedron cells.
//! `long` is taken as 64-bit. ASCII values of a `float` array are rounded
//! to single precision, as VTK stores them, so ASCII and binary files agree.
//!
//! Errors give the line (text parts) or the byte offset (binary data) and
//! say what was expected there: a truncated binary block reports how many
//! bytes were needed from which offset.

use std::path::Path;

use super::decompose::{vtk_type_name, CellShape, TetBuilder};
use super::numeric::{decode_f64, decode_i64, NumType};
use super::{line_of, read_bytes};
use crate::data::{Field, TetMesh};
use crate::error::{Error, Result};

/// Reads a VTK legacy unstructured grid from `path`.
pub fn read(path: &Path) -> Result<TetMesh> {
    let data = read_bytes(path)?;
    parse(&data, path)
}

/// Parses the bytes of a VTK legacy file; `path` is only used in errors.
pub fn parse(data: &[u8], path: &Path) -> Result<TetMesh> {
    Parser {
        d: data,
        pos: 0,
        path,
        binary: false,
    }
    .run()
}

/// Which attribute section the parser is in.
#[derive(Clone, Copy, PartialEq)]
enum Section {
    None,
    Point(usize),
    Cell(usize),
}

struct Parser<'a> {
    d: &'a [u8],
    pos: usize,
    path: &'a Path,
    binary: bool,
}

/// Cells as CSR: `offsets` has one more entry than there are cells.
struct Cells {
    offsets: Vec<i64>,
    conn: Vec<i64>,
    line: usize,
}

fn short(s: &str) -> String {
    if s.chars().count() > 60 {
        format!("{}...", s.chars().take(60).collect::<String>())
    } else {
        s.to_string()
    }
}

/// Decodes `%XX` escapes, as VTK writes spaces in array names as `%20`.
fn unescape(name: &str) -> String {
    let b = name.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = |c: u8| (c as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

impl<'a> Parser<'a> {
    fn at_line(&self, offset: usize, msg: impl Into<String>) -> Error {
        Error::data(self.path, format!("line {}", line_of(self.d, offset)), msg)
    }

    fn at_byte(&self, offset: usize, msg: impl Into<String>) -> Error {
        Error::data(self.path, format!("byte {offset}"), msg)
    }

    /// The next line, blank or not: `(start offset, text without the line end)`.
    fn raw_line(&mut self) -> Result<Option<(usize, &'a str)>> {
        if self.pos >= self.d.len() {
            return Ok(None);
        }
        let start = self.pos;
        let end = self.d[start..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(self.d.len(), |i| start + i);
        self.pos = (end + 1).min(self.d.len());
        let bytes = &self.d[start..end];
        let text = std::str::from_utf8(bytes).map_err(|_| {
            self.at_line(
                start,
                "expected a line of text (a keyword), found binary data",
            )
        })?;
        Ok(Some((start, text.trim_end_matches('\r'))))
    }

    /// The next non-blank line, trimmed.
    fn line(&mut self) -> Result<Option<(usize, &'a str)>> {
        loop {
            match self.raw_line()? {
                None => return Ok(None),
                Some((o, l)) if !l.trim().is_empty() => {
                    return Ok(Some((o + (l.len() - l.trim_start().len()), l.trim())))
                }
                Some(_) => {}
            }
        }
    }

    /// The first word (upper-cased) of the next non-blank line, without
    /// consuming it; `None` at the end or on binary data.
    fn peek_keyword(&mut self) -> Option<String> {
        let save = self.pos;
        let kw = self
            .line()
            .ok()
            .flatten()
            .and_then(|(_, l)| l.split_whitespace().next().map(str::to_ascii_uppercase));
        self.pos = save;
        kw
    }

    fn num_type(&self, at: usize, name: &str) -> Result<NumType> {
        NumType::from_vtk_legacy(name).ok_or_else(|| {
            self.at_line(at, format!("unsupported data type \"{}\" (supported: float, double, char, unsigned_char, short, unsigned_short, int, unsigned_int, long, unsigned_long, vtktypeint64, vtktypeuint64)", short(name)))
        })
    }

    fn count(&self, at: usize, tok: Option<&str>, what: &str) -> Result<usize> {
        let tok = tok.ok_or_else(|| self.at_line(at, format!("missing {what}")))?;
        tok.parse::<usize>().map_err(|_| {
            self.at_line(
                at,
                format!(
                    "{what} must be a non-negative integer, found \"{}\"",
                    short(tok)
                ),
            )
        })
    }

    /// Bytes of the next binary block of `n` values of `ty`.
    fn binary_block(&mut self, n: usize, ty: NumType, what: &str) -> Result<&'a [u8]> {
        let start = self.pos;
        let avail = self.d.len() - start;
        let need = n.checked_mul(ty.size()).filter(|&b| b <= avail).ok_or_else(|| {
            self.at_byte(
                start,
                format!("file is truncated: {what} needs {n} x {} = {} bytes of binary data from byte {start}, but only {avail} bytes remain", ty.size(), n as u128 * ty.size() as u128),
            )
        })?;
        self.pos += need;
        Ok(&self.d[start..start + need])
    }

    /// The next ASCII token and its offset.
    fn token(&mut self) -> Option<(usize, &'a [u8])> {
        let d = self.d;
        let mut i = self.pos;
        while i < d.len() && d[i].is_ascii_whitespace() {
            i += 1;
        }
        if i >= d.len() {
            self.pos = i;
            return None;
        }
        let start = i;
        while i < d.len() && !d[i].is_ascii_whitespace() {
            i += 1;
        }
        self.pos = i;
        Some((start, &d[start..i]))
    }

    fn ascii_values<T: std::str::FromStr>(
        &mut self,
        n: usize,
        ty: &str,
        what: &str,
    ) -> Result<Vec<T>> {
        let mut out = Vec::with_capacity(n.min(self.d.len() / 2 + 1));
        for k in 0..n {
            let (at, tok) = self.token().ok_or_else(|| {
                self.at_line(
                    self.d.len(),
                    format!("file ends after {k} of the {n} values of {what}"),
                )
            })?;
            let v = std::str::from_utf8(tok)
                .ok()
                .and_then(|s| s.parse::<T>().ok())
                .ok_or_else(|| {
                    self.at_line(
                        at,
                        format!(
                            "value {k} of {what}: \"{}\" is not a valid {ty} (expected {n} values)",
                            short(&String::from_utf8_lossy(tok))
                        ),
                    )
                })?;
            out.push(v);
        }
        Ok(out)
    }

    fn floats(&mut self, n: usize, ty: NumType, what: &str) -> Result<Vec<f64>> {
        if self.binary {
            Ok(decode_f64(self.binary_block(n, ty, what)?, ty, true))
        } else {
            let v: Vec<f64> = self.ascii_values(n, "number", what)?;
            // A `float` array holds single-precision values, as in VTK.
            Ok(if ty == NumType::F32 {
                v.into_iter().map(|x| x as f32 as f64).collect()
            } else {
                v
            })
        }
    }

    fn ints(&mut self, n: usize, ty: NumType, what: &str) -> Result<Vec<i64>> {
        if self.binary {
            let b = self.binary_block(n, ty, what)?;
            Ok(decode_i64(b, ty, true).unwrap_or_else(|| {
                decode_f64(b, ty, true)
                    .into_iter()
                    .map(|v| v as i64)
                    .collect()
            }))
        } else {
            self.ascii_values(n, "integer", what)
        }
    }

    fn header(&mut self) -> Result<()> {
        let first = self.d.split(|&b| b == b'\n').next().unwrap_or(&[]);
        let first = String::from_utf8_lossy(first);
        if !first
            .trim()
            .to_ascii_lowercase()
            .starts_with("# vtk datafile")
        {
            return Err(self.at_line(0, format!("not a VTK legacy file: the first line must be \"# vtk DataFile Version x.y\", found \"{}\"", short(first.trim()))));
        }
        self.raw_line()?;
        if self.raw_line()?.is_none() {
            return Err(self.at_line(
                self.d.len(),
                "file ends after the first line; expected a title, ASCII or BINARY, and DATASET",
            ));
        }
        let (at, enc) = self.line()?.ok_or_else(|| {
            self.at_line(self.d.len(), "file ends before the ASCII / BINARY line")
        })?;
        self.binary = match enc.to_ascii_uppercase().as_str() {
            "ASCII" => false,
            "BINARY" => true,
            other => {
                return Err(self.at_line(
                    at,
                    format!("expected ASCII or BINARY, found \"{}\"", short(other)),
                ))
            }
        };
        let (at, ds) = self
            .line()?
            .ok_or_else(|| self.at_line(self.d.len(), "file ends before the DATASET line"))?;
        let mut w = ds.split_whitespace();
        if !w.next().is_some_and(|k| k.eq_ignore_ascii_case("DATASET")) {
            return Err(self.at_line(
                at,
                format!(
                    "expected \"DATASET UNSTRUCTURED_GRID\", found \"{}\"",
                    short(ds)
                ),
            ));
        }
        match w.next().map(str::to_ascii_uppercase).as_deref() {
            Some("UNSTRUCTURED_GRID") => Ok(()),
            Some(t @ ("STRUCTURED_POINTS" | "STRUCTURED_GRID" | "RECTILINEAR_GRID" | "POLYDATA" | "FIELD")) => {
                Err(self.at_line(at, format!("dataset type {t} is not supported: pvrsim reads tetrahedral meshes (DATASET UNSTRUCTURED_GRID)")))
            }
            Some(t) => Err(self.at_line(at, format!("unknown dataset type \"{}\" (pvrsim reads UNSTRUCTURED_GRID)", short(t)))),
            None => Err(self.at_line(at, "DATASET line names no dataset type")),
        }
    }

    fn run(mut self) -> Result<TetMesh> {
        self.header()?;
        let mut points: Option<(Vec<[f64; 3]>, usize)> = None;
        let mut cells: Option<Cells> = None;
        let mut types: Option<(Vec<i64>, usize)> = None;
        let mut section = Section::None;
        let mut fields: Vec<Field> = Vec::new();

        while let Some((at, line)) = self.line()? {
            let mut w = line.split_whitespace();
            let kw = w.next().unwrap_or("").to_ascii_uppercase();
            match kw.as_str() {
                "POINTS" => {
                    let n = self.count(at, w.next(), "POINTS count")?;
                    let ty = self.num_type(at, w.next().unwrap_or("float"))?;
                    let v = self.floats(n.saturating_mul(3), ty, "POINTS")?;
                    points = Some((v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(), at));
                }
                "CELLS" => {
                    let a = self.count(at, w.next(), "CELLS count")?;
                    let b = self.count(at, w.next(), "CELLS size")?;
                    cells = Some(if self.peek_keyword().as_deref() == Some("OFFSETS") {
                        self.cells_51(at, a, b)?
                    } else {
                        self.cells_classic(at, a, b)?
                    });
                }
                "CELL_TYPES" => {
                    let n = self.count(at, w.next(), "CELL_TYPES count")?;
                    types = Some((self.ints(n, NumType::I32, "CELL_TYPES")?, at));
                }
                "POINT_DATA" | "CELL_DATA" => {
                    let n = self.count(at, w.next(), &format!("{kw} count"))?;
                    let (expected, what) = if kw == "POINT_DATA" {
                        section = Section::Point(n);
                        (points.as_ref().map(|p| p.0.len()), "points")
                    } else {
                        section = Section::Cell(n);
                        (
                            cells.as_ref().map(|c| c.offsets.len().saturating_sub(1)),
                            "cells",
                        )
                    };
                    if let Some(e) = expected.filter(|&e| e != n) {
                        return Err(self.at_line(
                            at,
                            format!("{kw} {n} disagrees with the mesh, which has {e} {what}"),
                        ));
                    }
                }
                "SCALARS"
                | "VECTORS"
                | "NORMALS"
                | "TENSORS"
                | "TENSORS6"
                | "TEXTURE_COORDINATES" => {
                    let name = w
                        .next()
                        .ok_or_else(|| self.at_line(at, format!("{kw} has no array name")))?;
                    let (ncomp, tyname) = match kw.as_str() {
                        "SCALARS" => {
                            let ty = w.next().unwrap_or("float");
                            (
                                w.next().map_or(Ok(1), |c| {
                                    self.count(at, Some(c), "SCALARS component count")
                                })?,
                                ty,
                            )
                        }
                        "TEXTURE_COORDINATES" => (
                            self.count(at, w.next(), "TEXTURE_COORDINATES dimension")?,
                            w.next().unwrap_or("float"),
                        ),
                        "TENSORS" => (9, w.next().unwrap_or("float")),
                        "TENSORS6" => (6, w.next().unwrap_or("float")),
                        _ => (3, w.next().unwrap_or("float")),
                    };
                    let ty = self.num_type(at, tyname)?;
                    let n = self.tuples(at, section, &kw)?;
                    if kw == "SCALARS" && self.peek_keyword().as_deref() == Some("LOOKUP_TABLE") {
                        self.line()?;
                    }
                    let values =
                        self.floats(n.saturating_mul(ncomp), ty, &format!("{kw} {name}"))?;
                    if let Section::Point(_) = section {
                        fields.push(Field {
                            name: unescape(name),
                            components: ncomp,
                            values,
                        });
                    }
                }
                "COLOR_SCALARS" => {
                    let name = w.next().unwrap_or("");
                    let ncomp = self.count(at, w.next(), "COLOR_SCALARS component count")?;
                    let n = self.tuples(at, section, &kw)?;
                    self.floats(
                        n.saturating_mul(ncomp),
                        NumType::U8,
                        &format!("COLOR_SCALARS {name}"),
                    )?;
                }
                "LOOKUP_TABLE" => {
                    let name = w.next().unwrap_or("");
                    let n = self.count(at, w.next(), "LOOKUP_TABLE size")?;
                    self.floats(
                        n.saturating_mul(4),
                        NumType::U8,
                        &format!("LOOKUP_TABLE {name}"),
                    )?;
                }
                "FIELD" => {
                    let _name = w.next();
                    let narrays = self.count(at, w.next(), "FIELD array count")?;
                    for _ in 0..narrays {
                        if self.peek_keyword().as_deref() == Some("METADATA") {
                            self.line()?;
                            self.skip_metadata()?;
                        }
                        let (at, l) = self.line()?.ok_or_else(|| {
                            self.at_line(
                                self.d.len(),
                                format!(
                                    "file ends inside FIELD data declared with {narrays} arrays"
                                ),
                            )
                        })?;
                        let mut w = l.split_whitespace();
                        let name = w.next().unwrap_or("");
                        if name == "NULL_ARRAY" {
                            continue;
                        }
                        let ncomp = self.count(at, w.next(), "FIELD array component count")?;
                        let ntuples = self.count(at, w.next(), "FIELD array tuple count")?;
                        let ty = self.num_type(at, w.next().unwrap_or(""))?;
                        if let Section::Point(n) | Section::Cell(n) = section {
                            if ntuples != n {
                                return Err(self.at_line(at, format!("FIELD array \"{}\" has {ntuples} tuples, but the section has {n}", short(name))));
                            }
                        }
                        let values = self.floats(
                            ncomp.saturating_mul(ntuples),
                            ty,
                            &format!("FIELD array {name}"),
                        )?;
                        if let Section::Point(_) = section {
                            fields.push(Field {
                                name: unescape(name),
                                components: ncomp,
                                values,
                            });
                        }
                    }
                }
                "METADATA" => self.skip_metadata()?,
                _ => {
                    return Err(self.at_line(at, format!("unknown keyword \"{}\" (expected POINTS, CELLS, CELL_TYPES, POINT_DATA, CELL_DATA, SCALARS, VECTORS, FIELD, ...)", short(w_first(line)))));
                }
            }
        }
        self.assemble(points, cells, types, fields)
    }

    /// Skips the body of a `METADATA` block (whose keyword line is already
    /// read): `INFORMATION n` with `NAME` / `DATA` lines, and
    /// `COMPONENT_NAMES` followed by names up to a blank line. Stops before
    /// the first other line.
    fn skip_metadata(&mut self) -> Result<()> {
        loop {
            let save = self.pos;
            let Ok(Some((_, l))) = self.raw_line() else {
                self.pos = save;
                return Ok(());
            };
            let first = l
                .split_whitespace()
                .next()
                .unwrap_or("")
                .to_ascii_uppercase();
            match first.as_str() {
                "" | "INFORMATION" | "NAME" | "DATA" => {}
                "COMPONENT_NAMES" => {
                    while let Ok(Some((_, l))) = self.raw_line() {
                        if l.trim().is_empty() {
                            break;
                        }
                    }
                }
                _ => {
                    self.pos = save;
                    return Ok(());
                }
            }
        }
    }

    /// Number of tuples in the current attribute section.
    fn tuples(&self, at: usize, section: Section, kw: &str) -> Result<usize> {
        match section {
            Section::Point(n) | Section::Cell(n) => Ok(n),
            Section::None => {
                Err(self.at_line(at, format!("{kw} appears before POINT_DATA or CELL_DATA")))
            }
        }
    }

    fn cells_classic(&mut self, at: usize, n: usize, size: usize) -> Result<Cells> {
        let data_at = self.pos;
        let raw = self.ints(size, NumType::I32, "CELLS")?;
        let mut offsets = Vec::with_capacity(n.min(raw.len()) + 1);
        let mut conn = Vec::with_capacity(raw.len().saturating_sub(n));
        offsets.push(0);
        let mut p = 0usize;
        for c in 0..n {
            let k = *raw.get(p).ok_or_else(|| self.at_line(at, format!("CELLS {n} {size}: the list of {size} integers ends at cell {c} (counts disagree with the data)")))?;
            if k < 0 || (k as u64) > (raw.len() - p - 1) as u64 {
                return Err(self.at_cells(data_at, at, format!("CELLS {n} {size}: cell {c} says it has {k} vertices, but only {} integers remain (counts disagree with the data)", raw.len() - p - 1)));
            }
            conn.extend_from_slice(&raw[p + 1..p + 1 + k as usize]);
            p += 1 + k as usize;
            offsets.push(conn.len() as i64);
        }
        if p != raw.len() {
            return Err(self.at_line(at, format!("CELLS {n} {size}: the {n} cells use {p} integers, not {size} (counts disagree with the data)")));
        }
        Ok(Cells {
            offsets,
            conn,
            line: at,
        })
    }

    fn at_cells(&self, data_at: usize, at: usize, msg: String) -> Error {
        if self.binary {
            self.at_byte(data_at, msg)
        } else {
            self.at_line(at, msg)
        }
    }

    fn cells_51(&mut self, at: usize, noff: usize, nconn: usize) -> Result<Cells> {
        let mut arrays = Vec::new();
        for expect in ["OFFSETS", "CONNECTIVITY"] {
            let (lat, l) = self.line()?.ok_or_else(|| {
                self.at_line(self.d.len(), format!("file ends before the {expect} array"))
            })?;
            let mut w = l.split_whitespace();
            if !w.next().is_some_and(|k| k.eq_ignore_ascii_case(expect)) {
                return Err(self.at_line(
                    lat,
                    format!(
                        "expected \"{expect} type\" (VTK 5.1 cell layout), found \"{}\"",
                        short(l)
                    ),
                ));
            }
            let ty = self.num_type(lat, w.next().unwrap_or("vtktypeint64"))?;
            let n = if expect == "OFFSETS" { noff } else { nconn };
            arrays.push(self.ints(n, ty, expect)?);
        }
        let conn = arrays.pop().unwrap_or_default();
        let offsets = arrays.pop().unwrap_or_default();
        if noff == 0 {
            return Ok(Cells {
                offsets: vec![0],
                conn,
                line: at,
            });
        }
        if offsets[0] != 0
            || offsets.windows(2).any(|w| w[1] < w[0])
            || offsets[noff - 1] != nconn as i64
        {
            return Err(self.at_line(at, format!("CELLS {noff} {nconn}: OFFSETS must rise from 0 to {nconn} (the CONNECTIVITY length); found {} .. {} (counts disagree with the data)", offsets[0], offsets[noff - 1])));
        }
        Ok(Cells {
            offsets,
            conn,
            line: at,
        })
    }

    fn assemble(
        &self,
        points: Option<(Vec<[f64; 3]>, usize)>,
        cells: Option<Cells>,
        types: Option<(Vec<i64>, usize)>,
        fields: Vec<Field>,
    ) -> Result<TetMesh> {
        let end = self.d.len();
        let (points, _) = points.ok_or_else(|| self.at_line(end, "no POINTS section"))?;
        let cells = cells.ok_or_else(|| self.at_line(end, "no CELLS section"))?;
        let (types, tat) = types.ok_or_else(|| self.at_line(end, "no CELL_TYPES section"))?;
        let ncells = cells.offsets.len() - 1;
        if types.len() != ncells {
            return Err(self.at_line(
                tat,
                format!(
                    "CELL_TYPES {} disagrees with CELLS (line {}), which has {ncells} cells",
                    types.len(),
                    line_of(self.d, cells.line)
                ),
            ));
        }
        let mut b = TetBuilder::new(&points, ncells);
        for (c, &t) in types.iter().enumerate() {
            let shape = CellShape::from_vtk(t).ok_or_else(|| {
                Error::data(self.path, format!("cell {c}"), format!("cell type {t} ({}) is not supported; pvrsim reads tetrahedra, hexahedra, voxels, wedges and pyramids, and skips lower-dimensional cells", vtk_type_name(t)))
            })?;
            let (s, e) = (cells.offsets[c] as usize, cells.offsets[c + 1] as usize);
            b.add(shape, &cells.conn[s..e])
                .map_err(|m| Error::data(self.path, format!("cell {c}"), m))?;
        }
        let tets = b.finish(self.path);
        Ok(TetMesh {
            points,
            tets,
            fields,
        })
    }
}

fn w_first(line: &str) -> &str {
    line.split_whitespace().next().unwrap_or("")
}
