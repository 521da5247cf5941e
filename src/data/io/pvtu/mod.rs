//! Reader for VTK's partitioned unstructured grids (`.pvtu`,
//! `<VTKFile type="PUnstructuredGrid">`): a small XML file that declares the
//! point-data arrays (`<PPointData>`, `<PPoints>`) and names one `.vtu` file
//! per piece (`<Piece Source="...">`), as a solver writes one per rank.
//!
//! A single process reads every piece (in parallel, each with the `.vtu`
//! reader) and returns their union. Piece names are resolved under the
//! `.pvtu`'s folder; an absolute name or one with `..` is refused as a
//! header's `data file:` names are ([`bounded::resolve_under`], unless
//! `PVRSIM_DATA_FILE_ANYWHERE=1`).
//!
//! Checked, each an error naming the `.pvtu` and the piece: a missing or
//! unreadable piece, a piece whose point-data arrays (names, types,
//! components) or points type differ from the declaration, and every error
//! the `.vtu` reader reports (truncation, out-of-range indices, ...).
//!
//! **Shared vertices.** Solvers duplicate the vertices on the boundary
//! between pieces. The union merges vertices that agree bit for bit in
//! position and in every field value ([`merge`]), so the union of a
//! partitioned mesh has the topology of the unpartitioned one (the face
//! adjacency is whole, the reference renderer's ray walk crosses piece
//! boundaries); vertices that differ in any value are kept apart.

pub mod merge;
pub mod summary;
pub mod write;

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::bounded;
use super::numeric::NumType;
use super::vtu::{self, get, Declared};
use crate::data::TetMesh;
use crate::error::{Error, Result};

/// The largest `.pvtu` file read (it only names pieces).
const MAX_PVTU_BYTES: u64 = 64 << 20;

/// What a `.pvtu` declares.
#[derive(Debug, Clone, PartialEq)]
pub struct PvtuHeader {
    /// The points' type in `<PPoints>`, if given.
    pub points_type: Option<NumType>,
    /// `<PPointData>` arrays: name, type, components.
    pub arrays: Declared,
    /// Each piece's `Source` as written and the path it resolves to.
    pub pieces: Vec<(String, PathBuf)>,
}

/// Reads and checks the `.pvtu` itself (not its pieces).
pub fn read_header(path: &Path) -> Result<PvtuHeader> {
    let text = bounded::read_limited(path, MAX_PVTU_BYTES, path, "file")?;
    let mut reader = quick_xml::Reader::from_reader(&text[..]);
    reader.config_mut().trim_text(true);
    let mut stack: Vec<String> = Vec::new();
    let mut head = PvtuHeader {
        points_type: None,
        arrays: Vec::new(),
        pieces: Vec::new(),
    };
    let mut seen_root = false;
    let mut buf = Vec::new();
    loop {
        let at = reader.buffer_position();
        let ev = reader.read_event_into(&mut buf).map_err(|e| {
            Error::data(path, format!("byte {at}"), format!("XML syntax error: {e}"))
        })?;
        use quick_xml::events::Event;
        let (e, empty) = match &ev {
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(_) => {
                stack.pop();
                buf.clear();
                continue;
            }
            Event::Eof => break,
            _ => {
                buf.clear();
                continue;
            }
        };
        let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
        let attrs: Vec<(String, String)> = e
            .attributes()
            .flatten()
            .map(|a| {
                (
                    String::from_utf8_lossy(a.key.local_name().as_ref()).into_owned(),
                    String::from_utf8_lossy(&a.value).into_owned(),
                )
            })
            .collect();
        match name.as_str() {
            "VTKFile" => {
                seen_root = true;
                let ty = get(&attrs, "type").unwrap_or("");
                if ty != "PUnstructuredGrid" {
                    return Err(Error::data(
                        path,
                        "<VTKFile>",
                        format!("type=\"{ty}\": a .pvtu must be type=\"PUnstructuredGrid\""),
                    ));
                }
            }
            "PDataArray" => {
                let parent = stack.last().map_or("", String::as_str);
                let aname = get(&attrs, "Name").unwrap_or("").to_string();
                let loc = || format!("<PDataArray Name=\"{aname}\"> in <{parent}>");
                let tyname = get(&attrs, "type").unwrap_or("");
                let ty = NumType::from_vtk_xml(tyname).ok_or_else(|| {
                    Error::data(path, loc(), format!("unsupported type \"{tyname}\""))
                })?;
                let ncomp = match get(&attrs, "NumberOfComponents") {
                    None => 1,
                    Some(c) => c
                        .trim()
                        .parse::<usize>()
                        .ok()
                        .filter(|&c| c >= 1)
                        .ok_or_else(|| {
                            Error::data(
                                path,
                                loc(),
                                format!("NumberOfComponents=\"{c}\" is not a positive integer"),
                            )
                        })?,
                };
                match parent {
                    "PPoints" => head.points_type = Some(ty),
                    "PPointData" => head.arrays.push((aname, ty, ncomp)),
                    _ => {}
                }
            }
            "Piece" => {
                let k = head.pieces.len();
                let src = get(&attrs, "Source").ok_or_else(|| {
                    Error::data(path, format!("<Piece> {k}"), "has no Source attribute")
                })?;
                let loc = format!("<Piece> {k} Source=\"{src}\"");
                let p = bounded::resolve_under(path, src, &loc)?;
                head.pieces.push((src.to_string(), p));
            }
            _ => {}
        }
        if !empty {
            stack.push(name);
        }
        buf.clear();
    }
    if !seen_root {
        return Err(Error::data(
            path,
            "file",
            "not a VTK XML file (no <VTKFile type=\"PUnstructuredGrid\">)",
        ));
    }
    if head.pieces.is_empty() {
        return Err(Error::data(
            path,
            "<PUnstructuredGrid>",
            "names no <Piece Source=\"...\">",
        ));
    }
    Ok(head)
}

/// Reads one piece of `head` and checks it against the declaration.
pub fn read_piece(path: &Path, head: &PvtuHeader, k: usize) -> Result<TetMesh> {
    read_piece_keeping(path, head, k, None)
}

/// [`read_piece`], decoding only the point-data array `keep` when one is
/// named (a worker reads the field it renders, not the solver's others).
pub fn read_piece_keeping(
    path: &Path,
    head: &PvtuHeader,
    k: usize,
    keep: Option<&str>,
) -> Result<TetMesh> {
    let (src, p) = &head.pieces[k];
    let at = |msg: String| Error::data(path, format!("<Piece> {k} Source=\"{src}\""), msg);
    let (mesh, pty, decl) = vtu::read_declared_keeping(p, keep).map_err(|e| at(e.to_string()))?;
    mesh.validate(p).map_err(|e| at(e.to_string()))?;
    check_piece(path, head, k, pty, &decl, mesh.points.is_empty())?;
    Ok(mesh)
}

/// Checks piece `k`'s points type `pty` and point-data arrays `decl`
/// against the `.pvtu`'s declaration (`empty`: the piece has no points, and
/// may then declare no arrays).
pub(crate) fn check_piece(
    path: &Path,
    head: &PvtuHeader,
    k: usize,
    pty: Option<NumType>,
    decl: &Declared,
    empty: bool,
) -> Result<()> {
    let (src, p) = &head.pieces[k];
    let at = |msg: String| Error::data(path, format!("<Piece> {k} Source=\"{src}\""), msg);
    if let (Some(want), Some(got)) = (head.points_type, pty) {
        if want != got {
            return Err(at(format!(
                "{}: its points are {got:?}, the .pvtu declares {want:?}",
                p.display()
            )));
        }
    }
    let show = |d: &Declared| {
        d.iter()
            .map(|(n, t, c)| format!("{n} ({t:?} x {c})"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    if empty && decl.is_empty() {
        return Ok(());
    }
    if *decl != head.arrays {
        return Err(at(format!(
            "{}: its point data [{}] differ from the .pvtu's <PPointData> [{}] (every piece must have the same arrays, types and components)",
            p.display(),
            show(decl),
            show(&head.arrays)
        )));
    }
    Ok(())
}

/// Reads a `.pvtu` and all its pieces (in parallel) into one mesh, merging
/// the vertices the pieces share (see the module documentation).
pub fn read(path: &Path) -> Result<TetMesh> {
    Ok(read_with_pieces(path)?.0)
}

/// [`read`], with each piece's tetrahedra (the union holds the pieces'
/// cells one piece after the other, in the `.pvtu`'s order).
pub fn read_with_pieces(path: &Path) -> Result<(TetMesh, Vec<u64>)> {
    let head = read_header(path)?;
    let meshes: Vec<Result<TetMesh>> = (0..head.pieces.len())
        .into_par_iter()
        .map(|k| read_piece(path, &head, k))
        .collect();
    let mut parts = Vec::with_capacity(meshes.len());
    for m in meshes {
        parts.push(m?);
    }
    let cells = parts.iter().map(|m| m.tets.len() as u64).collect();
    Ok((merge::merge_shared(merge::concat(parts)), cells))
}
