//! What a coordinator knows of a partitioned mesh without reading its
//! cells: per piece, its vertex count, declared cell count and the range of
//! the rendered field, with the caller's fold over its points in the same
//! pass ([`summarize`]); and the pieces' points again when another fold is
//! wanted ([`fold_points`]). The cells stay in the pieces, for the workers
//! that render them to read.
//!
//! Every piece is checked against the `.pvtu`'s declaration as the full
//! reader checks it ([`super::check_piece`]); errors name the piece.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::{check_piece, read_header, PvtuHeader};
use crate::data::io::vtu::vertices::{fold_vertices, VertexCounts};
use crate::error::{Error, Result};

/// One piece as [`summarize`] saw it.
#[derive(Debug, Clone, PartialEq)]
pub struct PieceInfo {
    /// Its `Source` as the `.pvtu` writes it.
    pub source: String,
    /// Its vertices.
    pub points: u64,
    /// Its cells as declared (`NumberOfCells`: before other cell types are
    /// made tetrahedra).
    pub cells_declared: u64,
    /// Smallest and largest value of the field's scalar (a vector's
    /// magnitude), `None` when it has no vertices.
    pub scalar_range: Option<[f64; 2]>,
}

/// A `.pvtu` and its pieces' [`PieceInfo`].
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// The `.pvtu` file.
    pub path: PathBuf,
    /// What it declares.
    pub head: PvtuHeader,
    /// One per piece, in the `.pvtu`'s order.
    pub pieces: Vec<PieceInfo>,
}

impl Summary {
    /// Every piece's vertices.
    pub fn points(&self) -> u64 {
        self.pieces.iter().map(|p| p.points).sum()
    }

    /// The field's range over every piece (`None`: no vertices at all).
    pub fn scalar_range(&self) -> Option<[f64; 2]> {
        self.pieces
            .iter()
            .filter_map(|p| p.scalar_range)
            .reduce(|a, b| [a[0].min(b[0]), a[1].max(b[1])])
    }
}

/// Reads the `.pvtu` at `path` and each piece's points and field `field`
/// (in parallel, one piece per thread, a chunk at a time: never the cells,
/// never a piece's vertices at once), checking each against the
/// declaration; folds `f` over each piece's points from `init` in the same
/// pass (one result per piece, in the pieces' order).
pub fn summarize<T: Send + Clone + Sync>(
    path: &Path,
    field: &str,
    init: T,
    f: impl Fn(&mut T, &[[f64; 3]]) + Sync,
) -> Result<(Summary, Vec<T>)> {
    let head = read_header(path)?;
    let (pieces, folded): (Vec<PieceInfo>, Vec<T>) = (0..head.pieces.len())
        .into_par_iter()
        .map(|k| {
            let mut acc = init.clone();
            let mut range = [f64::INFINITY, f64::NEG_INFINITY];
            let n = fold(
                path,
                &head,
                k,
                Some(field),
                |pts| f(&mut acc, pts),
                |v, c| {
                    for x in crate::data::mesh::scalar_of(v, c) {
                        range = [range[0].min(x), range[1].max(x)];
                    }
                },
            )?;
            let info = PieceInfo {
                source: head.pieces[k].0.clone(),
                points: n.points,
                cells_declared: n.cells_declared,
                scalar_range: (n.points > 0).then_some(range),
            };
            Ok((info, acc))
        })
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .unzip();
    Ok((
        Summary {
            path: path.to_path_buf(),
            head,
            pieces,
        },
        folded,
    ))
}

/// `f` folded over each piece's points (in parallel, one piece per
/// thread, a chunk at a time) from `init`: one result per piece, in the
/// pieces' order.
pub fn fold_points<T: Send + Clone + Sync>(
    s: &Summary,
    init: T,
    f: impl Fn(&mut T, &[[f64; 3]]) + Sync,
) -> Result<Vec<T>> {
    (0..s.pieces.len())
        .into_par_iter()
        .map(|k| {
            let mut acc = init.clone();
            fold(&s.path, &s.head, k, None, |p| f(&mut acc, p), |_, _| {})?;
            Ok(acc)
        })
        .collect()
}

/// Piece `k`'s vertices (and `field`) folded, checked against the
/// declaration (finite positions and values); errors name the `.pvtu` and
/// the piece.
fn fold(
    path: &Path,
    head: &PvtuHeader,
    k: usize,
    field: Option<&str>,
    mut on_points: impl FnMut(&[[f64; 3]]),
    mut on_values: impl FnMut(&[f64], usize),
) -> Result<VertexCounts> {
    let (src, p) = &head.pieces[k];
    let at = |msg: String| Error::data(path, format!("<Piece> {k} Source=\"{src}\""), msg);
    let mut bad_point: Option<u64> = None;
    let mut bad_value = false;
    let mut seen = 0u64;
    let (n, pty, decl) = fold_vertices(
        p,
        field,
        |pts| {
            if bad_point.is_none() {
                if let Some(i) = pts.iter().position(|q| q.iter().any(|x| !x.is_finite())) {
                    bad_point = Some(seen + i as u64);
                }
            }
            seen += pts.len() as u64;
            on_points(pts);
        },
        |v, c| {
            bad_value |= v.iter().any(|x| !x.is_finite());
            on_values(v, c);
        },
    )
    .map_err(|e| at(e.to_string()))?;
    if let Some(i) = bad_point {
        return Err(at(format!("{}: point {i} is not finite", p.display())));
    }
    if bad_value {
        return Err(at(format!(
            "{}: a value of \"{}\" is not finite",
            p.display(),
            field.unwrap_or_default()
        )));
    }
    check_piece(path, head, k, pty, &decl, n.points == 0)?;
    Ok(n)
}
