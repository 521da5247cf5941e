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
use super::line_of;
use super::mapped::FileBytes;
use super::numeric::{decode_f64, decode_i64, decode_points, NumType};
use crate::data::{Field, TetMesh};
use crate::error::{Error, Result};

mod cells;
mod lexer;

/// Reads a VTK legacy unstructured grid from `path`.
///
/// The file is memory-mapped and binary blocks are decoded on all cores;
/// the pages of each block are given back once it is decoded, so the
/// file's bytes and the mesh are not both resident.
pub fn read(path: &Path) -> Result<TetMesh> {
    let data = FileBytes::open(path)?;
    Parser {
        d: &data,
        pos: 0,
        path,
        binary: false,
        file: Some(&data),
    }
    .run()
}

/// Parses the bytes of a VTK legacy file; `path` is only used in errors.
pub fn parse(data: &[u8], path: &Path) -> Result<TetMesh> {
    Parser {
        d: data,
        pos: 0,
        path,
        binary: false,
        file: None,
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
    /// The mapped file, whose decoded blocks are released.
    file: Option<&'a FileBytes>,
}

/// Cells as CSR: `offsets` has one more entry than there are cells; or,
/// when every cell of a binary file is a 4-vertex cell, the checked
/// tetrahedra themselves (`tets`, with `offsets` and `conn` empty).
struct Cells {
    offsets: Vec<i64>,
    conn: Vec<i64>,
    line: usize,
    /// 4-vertex cells, every index checked below `tets.1` points.
    tets: Option<(Vec<[u32; 4]>, usize)>,
}

impl Cells {
    fn count(&self) -> usize {
        match &self.tets {
            Some((t, _)) => t.len(),
            None => self.offsets.len().saturating_sub(1),
        }
    }
}

/// `CELL_TYPES`: the codes, or (binary fast path) `n` cells all of type 10.
enum TypeList {
    Codes(Vec<i64>),
    AllTetra(usize),
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
        let mut types: Option<(TypeList, usize)> = None;
        let mut section = Section::None;
        let mut fields: Vec<Field> = Vec::new();

        while let Some((at, line)) = self.line()? {
            let mut w = line.split_whitespace();
            let kw = w.next().unwrap_or("").to_ascii_uppercase();
            match kw.as_str() {
                "POINTS" => {
                    let n = self.count(at, w.next(), "POINTS count")?;
                    let ty = self.num_type(at, w.next().unwrap_or("float"))?;
                    points = Some((self.points(n, ty)?, at));
                }
                "CELLS" => {
                    let a = self.count(at, w.next(), "CELLS count")?;
                    let b = self.count(at, w.next(), "CELLS size")?;
                    let np = points.as_ref().map(|p| p.0.len());
                    cells = Some(if self.peek_keyword().as_deref() == Some("OFFSETS") {
                        self.cells_51(at, a, b, np)?
                    } else {
                        self.cells_classic(at, a, b, np)?
                    });
                }
                "CELL_TYPES" => {
                    let n = self.count(at, w.next(), "CELL_TYPES count")?;
                    types = Some((self.cell_types(n)?, at));
                }
                "POINT_DATA" | "CELL_DATA" => {
                    let n = self.count(at, w.next(), &format!("{kw} count"))?;
                    let (expected, what) = if kw == "POINT_DATA" {
                        section = Section::Point(n);
                        (points.as_ref().map(|p| p.0.len()), "points")
                    } else {
                        section = Section::Cell(n);
                        (cells.as_ref().map(Cells::count), "cells")
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
}

fn w_first(line: &str) -> &str {
    line.split_whitespace().next().unwrap_or("")
}
