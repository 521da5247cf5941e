//! CELLS in both layouts (classic counts and 5.1 offsets + connectivity)
//! and the assembly of points, cells and types into tetrahedra.

use super::*;
use crate::data::io::numeric::{big_vec, decode_counted_tets_into, decode_tets, is_arithmetic};

impl<'a> Parser<'a> {
    pub(super) fn cells_classic(
        &mut self,
        at: usize,
        n: usize,
        size: usize,
        npoints: Option<usize>,
    ) -> Result<Cells> {
        let data_at = self.pos;
        if let Some(np) = npoints.filter(|_| self.binary && Some(size) == n.checked_mul(5)) {
            // Fast path: every cell `4 i0 i1 i2 i3`, indices in range,
            // decoded on all cores; anything else takes the general path
            // below, which names the fault.
            let b = self.binary_block(size, NumType::I32, "CELLS")?;
            // In slabs of 1 Mi cells, each slab's pages given back once
            // decoded: the block is never wholly resident beside the tets.
            const SLAB: usize = 1 << 20;
            let mut t = big_vec(n, [0u32; 4]);
            let ok = t
                .chunks_mut(SLAB)
                .zip(b.chunks(SLAB * 20))
                .enumerate()
                .all(|(i, (o, bs))| {
                    let good = decode_counted_tets_into(bs, NumType::I32, true, np, o);
                    if let Some(f) = self.file {
                        f.release(data_at + i * SLAB * 20, data_at + (i + 1) * SLAB * 20);
                    }
                    good
                });
            if ok {
                self.release_from(data_at);
                return Ok(Cells {
                    offsets: Vec::new(),
                    conn: Vec::new(),
                    line: at,
                    tets: Some((t, np)),
                });
            }
            self.pos = data_at;
        }
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
            tets: None,
        })
    }

    pub(super) fn at_cells(&self, data_at: usize, at: usize, msg: String) -> Error {
        if self.binary {
            self.at_byte(data_at, msg)
        } else {
            self.at_line(at, msg)
        }
    }

    pub(super) fn cells_51(
        &mut self,
        at: usize,
        noff: usize,
        nconn: usize,
        npoints: Option<usize>,
    ) -> Result<Cells> {
        let mut arrays = Vec::new();
        let mut raw: Vec<(usize, NumType)> = Vec::new();
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
            if let (true, Some(np)) = (self.binary && noff >= 1, npoints) {
                // Fast path (all 4-vertex cells): offsets checked to be 0, 4,
                // 8, ... and the connectivity decoded into checked tetrahedra.
                let start = self.pos;
                let b = self.binary_block(n, ty, expect)?;
                raw.push((start, ty));
                if expect == "CONNECTIVITY" {
                    let (ostart, oty) = raw[0];
                    let ob = &self.d[ostart..ostart + noff * oty.size()];
                    if Some(nconn) == (noff - 1).checked_mul(4) && is_arithmetic(ob, oty, true, 4) {
                        if let Some(t) = decode_tets(b, ty, true, np) {
                            self.release_from(ostart);
                            return Ok(Cells {
                                offsets: Vec::new(),
                                conn: Vec::new(),
                                line: at,
                                tets: Some((t, np)),
                            });
                        }
                    }
                }
                self.pos = start;
            }
            arrays.push(self.ints(n, ty, expect)?);
        }
        let conn = arrays.pop().unwrap_or_default();
        let offsets = arrays.pop().unwrap_or_default();
        if noff == 0 {
            return Ok(Cells {
                offsets: vec![0],
                conn,
                line: at,
                tets: None,
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
            tets: None,
        })
    }

    pub(super) fn assemble(
        &self,
        points: Option<(Vec<[f64; 3]>, usize)>,
        cells: Option<Cells>,
        types: Option<(TypeList, usize)>,
        fields: Vec<Field>,
    ) -> Result<TetMesh> {
        let end = self.d.len();
        let (points, _) = points.ok_or_else(|| self.at_line(end, "no POINTS section"))?;
        let mut cells = cells.ok_or_else(|| self.at_line(end, "no CELLS section"))?;
        let (types, tat) = types.ok_or_else(|| self.at_line(end, "no CELL_TYPES section"))?;
        if let (Some((tets, np)), TypeList::AllTetra(n)) = (&cells.tets, &types) {
            if *n == tets.len() && *np == points.len() {
                let tets = cells.tets.take().map(|t| t.0).unwrap_or_default();
                return Ok(TetMesh {
                    points,
                    tets,
                    fields,
                });
            }
        }
        // The general path: the fast path's results back in CSR form.
        if let Some((tets, _)) = cells.tets.take() {
            cells.offsets = (0..=tets.len() as i64).map(|i| 4 * i).collect();
            cells.conn = tets.iter().flatten().map(|&v| v as i64).collect();
        }
        let types = match types {
            TypeList::Codes(c) => c,
            TypeList::AllTetra(n) => vec![10; n],
        };
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
