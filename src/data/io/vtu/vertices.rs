//! A `.vtu`'s vertices without its cells: the points and one point-data
//! array of every `<Piece>`, and the cell count each piece declares. What a
//! coordinator needs of a partitioned mesh's pieces (their bounds, their
//! field's range) without reading the cells, which stay with the workers.

use super::*;

/// The vertex data of a `.vtu` ([`read_vertices`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Vertices {
    /// Positions, every piece's in turn.
    pub points: Vec<[f64; 3]>,
    /// The field's values, `components` per point.
    pub values: Vec<f64>,
    /// Components of the field.
    pub components: usize,
    /// Cells the file declares (`NumberOfCells`, before tetrahedra are made
    /// of other cell types).
    pub cells_declared: u64,
}

/// Reads the points of `path` and, if named, its point-data array `field`
/// (all its components), not the cells. The points' type and the declared arrays
/// are returned as [`super::read_declared`] returns them. A missing field is
/// an error naming the arrays there are.
pub(crate) fn read_vertices(
    path: &Path,
    field: Option<&str>,
) -> Result<(Vertices, Option<NumType>, Declared)> {
    let data = FileBytes::open(path)?;
    let s = scan(&data, path, "UnstructuredGrid")?;
    let first = s.pieces.first();
    let pty = first.and_then(|p| p.points.as_ref()).map(|a| a.ty);
    let decl: Declared = first.map_or(Vec::new(), |p| {
        p.point_data
            .iter()
            .map(|a| (a.name.clone(), a.ty, a.ncomp))
            .collect()
    });
    let mut v = Vertices::default();
    for (pi, p) in s.pieces.iter().enumerate() {
        v.cells_declared += p.ncells as u64;
        if p.npoints == 0 {
            continue;
        }
        let pa = p.points.as_ref().ok_or_else(|| {
            Error::data(path, format!("<Piece> {pi} <Points>"), "no points array")
        })?;
        if pa.ncomp != 3 {
            return Err(s.ctx.err(
                pa,
                format!("points need NumberOfComponents=\"3\", found {}", pa.ncomp),
            ));
        }
        let xyz = s.ctx.f64s(pa, p.npoints.saturating_mul(3))?;
        v.points
            .extend(xyz.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
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
        v.components = a.ncomp;
        v.values
            .extend(s.ctx.f64s(a, p.npoints.saturating_mul(a.ncomp))?);
    }
    Ok((v, pty, decl))
}
