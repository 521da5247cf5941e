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

/// A piece's cells: decoded straight into tetrahedra (indices already
/// offset), or in the general form.
enum Part {
    Tets(Vec<[u32; 4]>),
    Cells(PieceCells),
}

impl PieceCells {
    /// The general form of tetrahedra already offset (base 0).
    fn of_tets(t: &[[u32; 4]]) -> PieceCells {
        PieceCells {
            types: vec![10; t.len()],
            offs: (1..=t.len() as i64).map(|i| 4 * i).collect(),
            conn: t.iter().flat_map(|c| c.map(i64::from)).collect(),
            base: 0,
        }
    }

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
    let mut cells: Vec<(Part, usize)> = Vec::new();
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
            ctx.release(pa);
            points.extend(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        }
        for a in &p.point_data {
            let v = ctx.f64s(a, p.npoints.saturating_mul(a.ncomp))?;
            ctx.release(a);
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
            if let Some(tets) = direct_tets(ctx, [oa, ta, ca], p.ncells, p.npoints, base)? {
                cells.push((Part::Tets(tets), p.npoints));
                continue;
            }
            let offs = ctx.i64s(oa, p.ncells)?;
            ctx.release(oa);
            let types = ctx.i64s(ta, p.ncells)?;
            ctx.release(ta);
            let nconn = *offs.last().unwrap_or(&0);
            if nconn < 0 || offs.windows(2).any(|w| w[1] < w[0]) || offs[0] < 0 {
                return Err(ctx.err(oa, "offsets must be non-negative and non-decreasing"));
            }
            let conn = ctx.i64s(ca, nconn as usize)?;
            ctx.release(ca);
            cells.push((
                Part::Cells(PieceCells {
                    types,
                    offs,
                    conn,
                    base,
                }),
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
    // Fast path: every piece all tetrahedra with indices in range (read
    // straight into tetrahedra, or found so now).
    let cells: Vec<Part> = cells
        .into_iter()
        .map(|(c, np)| match c {
            Part::Cells(pc) => match pc.all_tets(np) {
                Some(t) => Part::Tets(t),
                None => Part::Cells(pc),
            },
            tets => tets,
        })
        .collect();
    if cells.iter().all(|c| matches!(c, Part::Tets(_))) {
        let mut parts: Vec<Vec<[u32; 4]>> = cells
            .into_iter()
            .filter_map(|c| match c {
                Part::Tets(t) => Some(t),
                Part::Cells(_) => None,
            })
            .collect();
        // One piece's array is kept, not copied.
        let tets = match parts.len() {
            1 => parts.pop().unwrap_or_default(),
            _ => parts.concat(),
        };
        return Ok(TetMesh {
            points,
            tets,
            fields,
        });
    }
    // The general path, in file order (pieces read directly back in its form).
    let cells: Vec<PieceCells> = cells
        .into_iter()
        .map(|c| match c {
            Part::Cells(c) => c,
            Part::Tets(t) => PieceCells::of_tets(&t),
        })
        .collect();
    let total: usize = cells.iter().map(|c| c.types.len()).sum();
    let mut b = TetBuilder::new(&points, total);
    let mut c = 0usize;
    let mut verts: Vec<i64> = Vec::new();
    for pc in &cells {
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

/// A piece's `ncells` cells decoded straight into tetrahedra (indices
/// offset by `base`) when every cell is a tetrahedron (offsets every 4,
/// types all 10) and every index is inside the piece's `npoints`: the
/// offsets and types are checked in chunks and the connectivity decoded
/// into `[u32; 4]`, never into 64-bit arrays. `None` to take the general
/// path, which decodes them again and names what is wrong.
fn direct_tets(
    ctx: &Ctx,
    [oa, ta, ca]: [&ArrayDesc; 3],
    ncells: usize,
    npoints: usize,
    base: i64,
) -> Result<Option<Vec<[u32; 4]>>> {
    let binary = |a: &ArrayDesc| a.format != Format::Ascii && !a.ty.is_float();
    if !(binary(oa) && binary(ta) && binary(ca)) {
        return Ok(None);
    }
    if !all_values(ctx, oa, ncells, |i, e| e == 4 * (i as i64 + 1))? {
        return Ok(None);
    }
    ctx.release(oa);
    if !all_values(ctx, ta, ncells, |_, t| t == 10)? {
        return Ok(None);
    }
    ctx.release(ta);
    let b = ctx.bytes(ca)?;
    if b.len() % ca.ty.size() != 0 || b.len() / ca.ty.size() != 4 * ncells {
        return Ok(None);
    }
    let Some(mut tets) = crate::data::io::numeric::decode_tets(&b, ca.ty, ctx.big_endian, npoints)
    else {
        return Ok(None);
    };
    drop(b);
    ctx.release(ca);
    if base != 0 {
        use rayon::prelude::*;
        let base = base as u32;
        tets.par_iter_mut().for_each(|t| *t = t.map(|v| v + base));
    }
    Ok(Some(tets))
}

/// Whether integer array `a` holds `n` values, each `ok(index, value)`,
/// decoded in chunks on all cores (no array of the values is made).
fn all_values(
    ctx: &Ctx,
    a: &ArrayDesc,
    n: usize,
    ok: impl Fn(usize, i64) -> bool + Sync,
) -> Result<bool> {
    use rayon::prelude::*;
    const CHUNK: usize = 1 << 16;
    let b = ctx.bytes(a)?;
    let sz = a.ty.size();
    if b.len() % sz != 0 || b.len() / sz != n {
        return Ok(false);
    }
    Ok(b.par_chunks(CHUNK * sz).enumerate().all(|(k, c)| {
        let mut v = vec![0i64; c.len() / sz];
        crate::data::io::numeric::decode_i64_into(c, a.ty, ctx.big_endian, &mut v)
            && v.iter().enumerate().all(|(i, &x)| ok(k * CHUNK + i, x))
    }))
}
