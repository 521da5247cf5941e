//! Reader for AVS UCD ASCII files (`.inp`), the single-step layout:
//!
//! ```text
//! # optional comment lines
//! nnodes ncells ndata_node ndata_cell ndata_model
//! id x y z                       (nnodes lines; ids are arbitrary integers)
//! id material type v0 v1 ...     (ncells lines; type pt line tri quad tet pyr prism hex)
//! ncomp size1 size2 ...          (node data, if ndata_node > 0)
//! label, unit                    (ncomp lines)
//! id v1 v2 ...                   (nnodes lines, size1 + size2 + ... values each)
//! ... cell data (skipped) and model data (skipped)
//! ```
//!
//! Node ids are mapped to indices in file order. Each node-data component
//! becomes a [`Field`] named by its label (text before the comma) with
//! `size` components. Tetrahedra are converted to the VTK vertex order
//! (AVS lists them with the opposite orientation, as meshio also assumes:
//! vertices 2 and 3 are swapped); pyramids (apex first in AVS) and prisms and
//! hexahedra are reordered to VTK order and decomposed as described in
//! [`decompose`](super::decompose); `pt`, `line`, `tri` and `quad` cells are
//! skipped with a warning.
//!
//! Not supported: the binary UCD format and the multi-step ASCII format
//! (whose first line is a step count) — those are errors at line 1 or 2.
//! Errors name the line.

use std::collections::HashMap;
use std::path::Path;

use super::decompose::{CellShape, TetBuilder};
use super::read_bytes;
use crate::data::{Field, TetMesh};
use crate::error::{Error, Result};

/// Reads an AVS UCD ASCII mesh from `path`.
pub fn read(path: &Path) -> Result<TetMesh> {
    let bytes = read_bytes(path)?;
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        Error::data(
            path,
            format!("byte {}", e.valid_up_to()),
            "not a text file (AVS UCD binary files are not supported)",
        )
    })?;
    parse(text, path)
}

struct Lines<'a> {
    it: std::iter::Enumerate<std::str::Lines<'a>>,
    path: &'a Path,
    last: usize,
}

impl<'a> Lines<'a> {
    /// The next line that is neither blank nor a `#` comment: (1-based number, words).
    fn next(&mut self, what: &str) -> Result<(usize, Vec<&'a str>)> {
        for (i, l) in self.it.by_ref() {
            self.last = i + 1;
            let t = l.trim();
            if !t.is_empty() && !t.starts_with('#') {
                return Ok((i + 1, t.split_whitespace().collect()));
            }
        }
        Err(Error::data(
            self.path,
            format!("line {}", self.last + 1),
            format!("file ends before {what}"),
        ))
    }

    fn err(&self, line: usize, msg: impl Into<String>) -> Error {
        Error::data(self.path, format!("line {line}"), msg)
    }
}

fn num<T: std::str::FromStr>(
    lines: &Lines,
    line: usize,
    words: &[&str],
    k: usize,
    what: &str,
) -> Result<T> {
    let w = words
        .get(k)
        .ok_or_else(|| lines.err(line, format!("missing {what} (word {} of the line)", k + 1)))?;
    w.parse::<T>()
        .map_err(|_| lines.err(line, format!("{what}: \"{w}\" is not a valid number")))
}

/// Parses the text of an AVS UCD file; `path` is only used in errors.
pub fn parse(text: &str, path: &Path) -> Result<TetMesh> {
    let mut lines = Lines {
        it: text.lines().enumerate(),
        path,
        last: 0,
    };
    let (hl, h) = lines.next("the header line")?;
    if h.len() != 5 {
        return Err(lines.err(hl, format!("expected the header \"nnodes ncells ndata_node ndata_cell ndata_model\" (5 integers), found {} words; multi-step and binary UCD files are not supported", h.len())));
    }
    let nnodes: usize = num(&lines, hl, &h, 0, "node count")?;
    let ncells: usize = num(&lines, hl, &h, 1, "cell count")?;
    let ndata_node: usize = num(&lines, hl, &h, 2, "node data count")?;

    let mut ids: HashMap<i64, u32> = HashMap::with_capacity(nnodes.min(text.len() / 8));
    let mut points = Vec::with_capacity(nnodes.min(text.len() / 8));
    for i in 0..nnodes {
        let (ln, w) = lines.next(&format!("node {} of {nnodes}", i + 1))?;
        let id: i64 = num(&lines, ln, &w, 0, "node id")?;
        let p = [
            num(&lines, ln, &w, 1, "x")?,
            num(&lines, ln, &w, 2, "y")?,
            num(&lines, ln, &w, 3, "z")?,
        ];
        if ids.insert(id, i as u32).is_some() {
            return Err(lines.err(ln, format!("node id {id} is defined twice")));
        }
        points.push(p);
    }

    let mut b = TetBuilder::new(&points, ncells);
    for c in 0..ncells {
        let (ln, w) = lines.next(&format!("cell {} of {ncells}", c + 1))?;
        let ty = w
            .get(2)
            .ok_or_else(|| lines.err(ln, "expected \"id material type v0 v1 ...\""))?
            .to_ascii_lowercase();
        let (shape, order): (CellShape, &[usize]) = match ty.as_str() {
            "pt" => (CellShape::Skipped("point"), &[]),
            "line" => (CellShape::Skipped("line"), &[]),
            "tri" => (CellShape::Skipped("triangle"), &[]),
            "quad" => (CellShape::Skipped("quad"), &[]),
            "tet" => (CellShape::Tetra, &[0, 1, 3, 2]),
            "pyr" => (CellShape::Pyramid, &[1, 2, 3, 4, 0]),
            "prism" => (CellShape::Wedge, &[0, 1, 2, 3, 4, 5]),
            "hex" => (CellShape::Hexahedron, &[0, 1, 2, 3, 4, 5, 6, 7]),
            other => return Err(lines.err(ln, format!("cell type \"{other}\" is not supported (supported: pt line tri quad tet pyr prism hex)"))),
        };
        if let CellShape::Skipped(_) = shape {
            b.add(shape, &[]).map_err(|m| lines.err(ln, m))?;
            continue;
        }
        let given = &w[3..];
        if given.len() != order.len() {
            return Err(lines.err(
                ln,
                format!(
                    "a {ty} cell has {} vertices, this line lists {}",
                    order.len(),
                    given.len()
                ),
            ));
        }
        let mut verts = Vec::with_capacity(order.len());
        for &k in order {
            let id: i64 = num(&lines, ln, &w, 3 + k, "vertex id")?;
            let v = ids.get(&id).ok_or_else(|| {
                lines.err(
                    ln,
                    format!(
                        "cell {} refers to node id {id}, which is not defined",
                        c + 1
                    ),
                )
            })?;
            verts.push(*v as i64);
        }
        b.add(shape, &verts).map_err(|m| lines.err(ln, m))?;
    }
    let tets = b.finish(path);

    let mut fields = Vec::new();
    if ndata_node > 0 {
        let (ln, w) = lines.next("the node data header \"ncomp size1 size2 ...\"")?;
        let ncomp: usize = num(&lines, ln, &w, 0, "node data component count")?;
        let mut sizes = Vec::with_capacity(ncomp.min(w.len()));
        for k in 0..ncomp {
            sizes.push(num::<usize>(&lines, ln, &w, k + 1, "component size")?);
        }
        if sizes.iter().any(|&s| s == 0 || s > 64) {
            return Err(lines.err(ln, "node data component sizes must be between 1 and 64"));
        }
        let total: usize = sizes.iter().sum();
        for (k, &s) in sizes.iter().enumerate() {
            let (_, lw) = lines.next(&format!("the label of node data component {}", k + 1))?;
            let joined = lw.join(" ");
            let label = joined.split(',').next().unwrap_or("").trim();
            let name = if label.is_empty() {
                format!("data{}", k + 1)
            } else {
                label.to_string()
            };
            fields.push(Field {
                name,
                components: s,
                values: vec![f64::NAN; s * points.len()],
            });
        }
        let mut seen = vec![false; nnodes];
        for _ in 0..nnodes {
            let (ln, w) = lines.next("node data values")?;
            let id: i64 = num(&lines, ln, &w, 0, "node id")?;
            let &i = ids.get(&id).ok_or_else(|| {
                lines.err(
                    ln,
                    format!("node data for node id {id}, which is not defined"),
                )
            })?;
            if std::mem::replace(&mut seen[i as usize], true) {
                return Err(lines.err(ln, format!("node data for node id {id} given twice")));
            }
            if w.len() != 1 + total {
                return Err(lines.err(
                    ln,
                    format!(
                        "expected the node id and {total} values, found {} values",
                        w.len() - 1
                    ),
                ));
            }
            let mut k = 1;
            for f in fields.iter_mut() {
                for c in 0..f.components {
                    f.values[i as usize * f.components + c] =
                        num(&lines, ln, &w, k, "node data value")?;
                    k += 1;
                }
            }
        }
    }
    Ok(TetMesh {
        points,
        tets,
        fields,
    })
}
