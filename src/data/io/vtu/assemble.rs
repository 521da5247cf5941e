//! Assembling a `.vtu`'s pieces into one mesh: points and point data
//! concatenated, cells through a parallel all-tetrahedra fast path or the
//! general per-cell path (other cell types, any fault, named by cell).

use super::*;

/// One piece's cells: types, end offsets, connectivity, and the index of
/// its first point in the whole mesh.
struct PieceCells {
    types: Vec<i64>,
    offs: Vec<i64>,
    conn: Vec<i64>,
    base: i64,
}

impl PieceCells {
    /// The piece's cells as tetrahedra if all are 4-vertex tetrahedra with
    /// indices inside the piece's `npoints` (checked on all cores).
    fn all_tets(&self, npoints: usize) -> Option<Vec<[u32; 4]>> {
        use rayon::prelude::*;
        let ok = self.types.par_iter().all(|&t| t == 10)
            && self.conn.len() == 4 * self.offs.len()
            && self
                .offs
                .par_iter()
                .enumerate()
                .all(|(i, &e)| e == 4 * (i as i64 + 1))
            && self
                .conn
                .par_iter()
                .all(|&v| v >= 0 && (v as u64) < npoints as u64);
        ok.then(|| {
            self.conn
                .par_chunks_exact(4)
                .map(|c| [0, 1, 2, 3].map(|k| (c[k] + self.base) as u32))
                .collect()
        })
    }
}

pub(super) fn assemble(ctx: &Ctx, pieces: Vec<PieceDesc>) -> Result<TetMesh> {
    let path = ctx.path;
    let mut points: Vec<[f64; 3]> = Vec::new();
    let mut fields: Vec<Field> = Vec::new();
    let mut cells: Vec<(PieceCells, usize)> = Vec::new();
    for (pi, p) in pieces.iter().enumerate() {
        let where_ = |what: &str| format!("<Piece> {pi} <{what}>");
        let base = points.len() as i64;
        if p.npoints > 0 {
            let pa = p
                .points
                .as_ref()
                .ok_or_else(|| Error::data(path, where_("Points"), "no points array"))?;
            if pa.ncomp != 3 {
                return Err(ctx.err(
                    pa,
                    format!("points need NumberOfComponents=\"3\", found {}", pa.ncomp),
                ));
            }
            let v = ctx.f64s(pa, p.npoints.saturating_mul(3))?;
            points.extend(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        }
        for a in &p.point_data {
            let v = ctx.f64s(a, p.npoints.saturating_mul(a.ncomp))?;
            if pi == 0 {
                fields.push(Field {
                    name: a.name.clone(),
                    components: a.ncomp,
                    values: v,
                });
            } else if let Some(f) = fields
                .iter_mut()
                .find(|f| f.name == a.name && f.components == a.ncomp)
            {
                f.values.extend(v);
            }
        }
        if p.ncells > 0 {
            let missing = |n: &str| Error::data(path, where_("Cells"), format!("no \"{n}\" array"));
            let oa = p.offsets.as_ref().ok_or_else(|| missing("offsets"))?;
            let ta = p.types.as_ref().ok_or_else(|| missing("types"))?;
            let ca = p.conn.as_ref().ok_or_else(|| missing("connectivity"))?;
            let offs = ctx.i64s(oa, p.ncells)?;
            let types = ctx.i64s(ta, p.ncells)?;
            let nconn = *offs.last().unwrap_or(&0);
            if nconn < 0 || offs.windows(2).any(|w| w[1] < w[0]) || offs[0] < 0 {
                return Err(ctx.err(oa, "offsets must be non-negative and non-decreasing"));
            }
            let conn = ctx.i64s(ca, nconn as usize)?;
            cells.push((
                PieceCells {
                    types,
                    offs,
                    conn,
                    base,
                },
                p.npoints,
            ));
        }
    }
    if let Some(f) = fields
        .iter()
        .find(|f| f.values.len() != f.components * points.len())
    {
        return Err(Error::data(
            path,
            format!("<DataArray Name=\"{}\"> in <PointData>", f.name),
            "the array is missing from some pieces",
        ));
    }
    // Fast path: every piece all tetrahedra with indices in range.
    let fast: Option<Vec<Vec<[u32; 4]>>> = cells.iter().map(|(c, np)| c.all_tets(*np)).collect();
    if let Some(parts) = fast {
        return Ok(TetMesh {
            points,
            tets: parts.concat(),
            fields,
        });
    }
    let total: usize = cells.iter().map(|(c, _)| c.types.len()).sum();
    let mut b = TetBuilder::new(&points, total);
    let mut c = 0usize;
    let mut verts: Vec<i64> = Vec::new();
    for (pc, _) in &cells {
        let mut s = 0usize;
        for (&e, &t) in pc.offs.iter().zip(&pc.types) {
            let e = e as usize;
            verts.clear();
            verts.extend(
                pc.conn[s..e]
                    .iter()
                    .map(|&v| if v < 0 { v } else { v + pc.base }),
            );
            s = e;
            let shape = CellShape::from_vtk(t).ok_or_else(|| {
                Error::data(path, format!("cell {c}"), format!("cell type {t} ({}) is not supported; pvrsim reads tetrahedra, hexahedra, voxels, wedges and pyramids, and skips lower-dimensional cells", vtk_type_name(t)))
            })?;
            b.add(shape, &verts)
                .map_err(|m| Error::data(path, format!("cell {c}"), m))?;
            c += 1;
        }
    }
    let tets = b.finish(path);
    Ok(TetMesh {
        points,
        tets,
        fields,
    })
}
