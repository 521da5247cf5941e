//! A `.vtu`'s vertices without its cells: the points and one point-data
//! array of every `<Piece>`, handed over in chunks, and the cell count each
//! piece declares. What a coordinator needs of a partitioned mesh's pieces
//! (their bounds, their field's range, a frame's depth range) without
//! reading the cells, which stay with the workers, and without holding the
//! vertices either: raw appended arrays are decoded from the mapped file a
//! chunk at a time.

use super::*;
use crate::data::io::numeric::decode_f64_into;

/// Values decoded per chunk.
const CHUNK: usize = 1 << 16;

/// What [`fold_vertices`] counted.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct VertexCounts {
    /// Vertices, every piece's.
    pub points: u64,
    /// Cells the file declares (`NumberOfCells`, before tetrahedra are made
    /// of other cell types).
    pub cells_declared: u64,
}

/// Reads the points of `path` and, if named, its point-data array `field`
/// (all its components), not the cells: `on_points` gets the positions and
/// `on_values` the field's values (whole vertices, `components` each) a
/// chunk at a time. The points' type and the declared arrays are returned
/// as [`super::read_declared_keeping`] returns them. A missing field is an error
/// naming the arrays there are.
pub(crate) fn fold_vertices(
    path: &Path,
    field: Option<&str>,
    mut on_points: impl FnMut(&[[f64; 3]]),
    mut on_values: impl FnMut(&[f64], usize),
) -> Result<(VertexCounts, Option<NumType>, Declared)> {
    let data = FileBytes::open(path)?;
    let s = scan(&data, path, "UnstructuredGrid")?;
    let (pty, decl) = declared(&s.pieces);
    let mut n = VertexCounts::default();
    let mut xyz: Vec<[f64; 3]> = Vec::new();
    for (pi, p) in s.pieces.iter().enumerate() {
        n.cells_declared += p.ncells as u64;
        if p.npoints == 0 {
            continue;
        }
        n.points += p.npoints as u64;
        let pa = p.points.as_ref().ok_or_else(|| {
            Error::data(path, format!("<Piece> {pi} <Points>"), "no points array")
        })?;
        if pa.ncomp != 3 {
            return Err(s.ctx.err(
                pa,
                format!("points need NumberOfComponents=\"3\", found {}", pa.ncomp),
            ));
        }
        chunks(&s.ctx, pa, p.npoints.saturating_mul(3), 3, |v| {
            xyz.clear();
            xyz.extend(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
            on_points(&xyz);
        })?;
        let Some(field) = field else {
            continue;
        };
        let a = p
            .point_data
            .iter()
            .find(|a| a.name == field)
            .ok_or_else(|| {
                let names: Vec<String> = p
                    .point_data
                    .iter()
                    .map(|a| format!("\"{}\"", a.name))
                    .collect();
                Error::data(
                    path,
                    format!("<Piece> {pi} <PointData>"),
                    format!(
                        "has no array \"{field}\"; it has: {}",
                        if names.is_empty() {
                            "none".to_string()
                        } else {
                            names.join(", ")
                        }
                    ),
                )
            })?;
        chunks(&s.ctx, a, p.npoints.saturating_mul(a.ncomp), a.ncomp, |v| {
            on_values(v, a.ncomp)
        })?;
    }
    Ok((n, pty, decl))
}

/// Array `a`'s `expected` values as `f64`, given to `f` a chunk at a time
/// (a whole number of `group`s each), checked as [`Ctx::f64s`] checks them.
fn chunks(
    ctx: &Ctx,
    a: &ArrayDesc,
    expected: usize,
    group: usize,
    mut f: impl FnMut(&[f64]),
) -> Result<()> {
    if a.format == Format::Ascii {
        f(&ctx.f64s(a, expected)?);
        return Ok(());
    }
    let b = ctx.bytes(a)?;
    ctx.check_len(a, b.len())?;
    let sz = a.ty.size();
    ctx.check_count(a, b.len() / sz, expected)?;
    let per = CHUNK / group.max(1) * group.max(1);
    let mut buf = vec![0.0f64; per.min(expected)];
    for c in b.chunks(per * sz) {
        let v = &mut buf[..c.len() / sz];
        decode_f64_into(c, a.ty, ctx.big_endian, v);
        f(v);
    }
    Ok(())
}
