//! The work unit that travels: with the initial placement, and with dynamic
//! load balancing (DLB) when a node gives part of its unprocessed cells away.
//!
//! A unit carries its cells and the vertex data they need, indexed locally:
//!
//! - per vertex: its **global id** (the key a node merges units' vertices
//!   by; scan conversion orients every face by its vertices' positions, ids
//!   breaking ties, so that the two cells sharing a face compute
//!   bit-identical planes wherever they are rendered — watertightness across
//!   nodes and across pieces), its world position (f64, so that every node projects it exactly
//!   as the single-machine renderer does) and its scalar, already normalised
//!   to the transfer function's `[0, 1]` scale (f32: the precision scan
//!   conversion uses);
//! - per cell: its global id and its four local vertex indices.
//!
//! Vertex ids are kept sorted ascending and unique (the canonical form, cheap
//! to check). Cells keep the order they were given in: for a unit produced
//! by a node that is its processing order, so the *last* cells are the ones
//! it would have processed last.
//!
//! ## Wire format and size
//!
//! bincode 1 with fixed-width integers, little endian, trailing bytes
//! rejected ([`WorkUnit::encode`]). The size is exact and simple:
//! `4 * 8` (the four vector lengths) `+ V * (4 + 24 + 4)`
//! `+ C * (4 + 16)` bytes for `V` vertices and `C` cells — about
//! `C * 20 + V * 32`; a unit of a compact mesh piece has `V ≈ C / 5`, so
//! roughly 26 bytes per cell. [`WorkUnit::encoded_size`] returns it without
//! encoding.
//!
//! ## Decoding hostile bytes
//!
//! [`WorkUnit::decode`] never panics: bincode is bounded by the input length
//! (a length prefix larger than the bytes left fails instead of allocating),
//! and [`WorkUnit::validate`] then checks every invariant scan conversion
//! relies on: matching lengths, sorted unique vertex ids, local indices in
//! range, unique cell ids, finite positions and scalars. A cell may repeat a
//! vertex (a collapsed tetrahedron, as `tests/data/spx.inp`'s cell 0 is, and
//! as the mesh readers keep it): scan conversion sets it up as degenerate and
//! counts it in `cells_degenerate`, as the single-machine renderer does.

use std::collections::HashMap;

use bincode::Options;
use serde::{Deserialize, Serialize};

use crate::data::TetMesh;

/// One cell of a work unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct WorkCell {
    /// Global cell id (index in the mesh).
    pub id: u32,
    /// Its four vertices, as indices into the unit's vertex arrays.
    pub v: [u32; 4],
}

/// Cells and the vertex data they need. See the module docs.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct WorkUnit {
    /// Global vertex ids, sorted ascending, unique.
    pub vertex_ids: Vec<u32>,
    /// World positions, one per vertex.
    pub positions: Vec<[f64; 3]>,
    /// Normalised scalars, one per vertex.
    pub scalars: Vec<f32>,
    /// The cells, in processing order.
    pub cells: Vec<WorkCell>,
}

/// Why bytes or a unit were rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WorkError {
    /// The bytes are not a bincode-encoded unit.
    #[error("work unit: malformed encoding: {0}")]
    Encoding(String),
    /// Vertex arrays of different lengths.
    #[error("work unit: {ids} vertex ids, {pos} positions, {s} scalars")]
    Lengths {
        /// Ids.
        ids: usize,
        /// Positions.
        pos: usize,
        /// Scalars.
        s: usize,
    },
    /// Vertex ids not strictly ascending.
    #[error("work unit: vertex ids not sorted and unique at index {0}")]
    VertexOrder(usize),
    /// A local vertex index out of range.
    #[error("work unit: cell {cell} has a bad vertex index")]
    CellVertex {
        /// Global cell id.
        cell: u32,
    },
    /// A cell id appears twice.
    #[error("work unit: cell {0} appears twice")]
    DuplicateCell(u32),
    /// A non-finite position or scalar.
    #[error("work unit: vertex {0} has a non-finite position or scalar")]
    NonFinite(u32),
    /// An id beyond the mesh's counts (see [`WorkUnit::validate_against`]).
    #[error("work unit: id {id} out of range (limit {limit})")]
    OutOfRange {
        /// The id.
        id: u32,
        /// The count it must stay below.
        limit: usize,
    },
}

fn options() -> impl Options {
    bincode::DefaultOptions::new()
        .with_fixint_encoding()
        .with_little_endian()
        .reject_trailing_bytes()
}

impl WorkUnit {
    /// The unit holding cells `cells` (global ids, in this order) of `mesh`,
    /// with normalised scalars `s_norm`.
    pub fn from_mesh(mesh: &TetMesh, s_norm: &[f64], cells: &[u32]) -> WorkUnit {
        WorkUnit::gather(cells.iter().map(|&c| (c, mesh.tets[c as usize])), |v| {
            (mesh.points[v as usize], s_norm[v as usize] as f32)
        })
    }

    /// The unit of `cells` (global id, global vertex ids), in this order;
    /// `vertex(id)` gives a vertex's position and normalised scalar.
    pub fn gather(
        cells: impl Iterator<Item = (u32, [u32; 4])> + Clone,
        vertex: impl Fn(u32) -> ([f64; 3], f32),
    ) -> WorkUnit {
        let mut ids: Vec<u32> = cells.clone().flat_map(|(_, v)| v).collect();
        ids.sort_unstable();
        ids.dedup();
        let local: HashMap<u32, u32> = ids
            .iter()
            .enumerate()
            .map(|(i, &g)| (g, i as u32))
            .collect();
        let (positions, scalars) = ids.iter().map(|&g| vertex(g)).unzip();
        WorkUnit {
            cells: cells
                .map(|(id, v)| WorkCell {
                    id,
                    v: v.map(|g| local[&g]),
                })
                .collect(),
            vertex_ids: ids,
            positions,
            scalars,
        }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether it holds no cell.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// Global vertex ids of cell `k`.
    pub fn global_ids(&self, k: usize) -> [u32; 4] {
        self.cells[k].v.map(|l| self.vertex_ids[l as usize])
    }

    /// The cells `[from..]` as a unit of their own (only the vertices they use).
    pub fn sub_unit(&self, from: usize) -> WorkUnit {
        WorkUnit::gather(
            self.cells[from..]
                .iter()
                .map(|c| (c.id, c.v.map(|l| self.vertex_ids[l as usize]))),
            |g| {
                let l = self.vertex_ids.binary_search(&g).expect("own vertex");
                (self.positions[l], self.scalars[l])
            },
        )
    }

    /// Splits off the last `floor(len * fraction)` cells (clamped to
    /// `[0, len]`) as a new unit and keeps the rest; both keep only the
    /// vertices they use.
    pub fn split_off_fraction(&mut self, fraction: f64) -> WorkUnit {
        let n = self.cells.len();
        let k = ((n as f64 * fraction.clamp(0.0, 1.0)).floor() as usize).min(n);
        let given = self.sub_unit(n - k);
        let mut kept = self.clone();
        kept.cells.truncate(n - k);
        *self = kept.sub_unit(0);
        given
    }

    /// The paper's DLB rule (§4.3.2), applied to a unit: split off a third
    /// (rounded down) of the cells — the **last** third, the cells the owner
    /// would process last. See [`super::renderer`] for why the last ones.
    pub fn split_off_third(&mut self) -> WorkUnit {
        self.split_off_fraction(1.0 / 3.0)
    }

    /// Bytes on the wire: exactly `encode().len()`.
    pub fn encoded_size(&self) -> u64 {
        options()
            .serialized_size(self)
            .expect("a unit always encodes")
    }

    /// The wire form (see the module docs).
    pub fn encode(&self) -> Vec<u8> {
        options().serialize(self).expect("a unit always encodes")
    }

    /// Decodes and validates bytes from the wire; never panics.
    pub fn decode(bytes: &[u8]) -> Result<WorkUnit, WorkError> {
        let unit: WorkUnit = options()
            .with_limit(bytes.len() as u64)
            .deserialize(bytes)
            .map_err(|e| WorkError::Encoding(e.to_string()))?;
        unit.validate()?;
        Ok(unit)
    }

    /// Checks every invariant of the module docs.
    pub fn validate(&self) -> Result<(), WorkError> {
        let nv = self.vertex_ids.len();
        if self.positions.len() != nv || self.scalars.len() != nv {
            return Err(WorkError::Lengths {
                ids: nv,
                pos: self.positions.len(),
                s: self.scalars.len(),
            });
        }
        if let Some(i) = self.vertex_ids.windows(2).position(|w| w[0] >= w[1]) {
            return Err(WorkError::VertexOrder(i + 1));
        }
        for (k, (p, s)) in self.positions.iter().zip(&self.scalars).enumerate() {
            if !(p.iter().all(|c| c.is_finite()) && s.is_finite()) {
                return Err(WorkError::NonFinite(self.vertex_ids[k]));
            }
        }
        for c in &self.cells {
            if c.v.iter().any(|&l| l as usize >= nv) {
                return Err(WorkError::CellVertex { cell: c.id });
            }
        }
        let mut ids: Vec<u32> = self.cells.iter().map(|c| c.id).collect();
        ids.sort_unstable();
        if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
            return Err(WorkError::DuplicateCell(w[0]));
        }
        Ok(())
    }

    /// [`WorkUnit::validate`], and every global vertex id below `n_vertices`
    /// and cell id below `n_cells` (the mesh's counts, known to every node).
    pub fn validate_against(&self, n_vertices: usize, n_cells: usize) -> Result<(), WorkError> {
        self.validate()?;
        if let Some(&id) = self
            .vertex_ids
            .last()
            .filter(|&&v| v as usize >= n_vertices)
        {
            return Err(WorkError::OutOfRange {
                id,
                limit: n_vertices,
            });
        }
        if let Some(c) = self.cells.iter().find(|c| c.id as usize >= n_cells) {
            return Err(WorkError::OutOfRange {
                id: c.id,
                limit: n_cells,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> WorkUnit {
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
        ];
        WorkUnit::gather(
            [
                (7u32, [0u32, 1, 2, 3]),
                (9, [1, 2, 3, 4]),
                (3, [4, 1, 2, 0]),
            ]
            .into_iter(),
            |g| (pts[g as usize], g as f32 * 0.1),
        )
    }

    #[test]
    fn round_trip_and_exact_size() {
        let u = unit();
        let b = u.encode();
        assert_eq!(b.len() as u64, u.encoded_size());
        assert_eq!(b.len(), 32 + 5 * 32 + 3 * 20);
        assert_eq!(WorkUnit::decode(&b).unwrap(), u);
        assert_eq!(u.global_ids(1), [1, 2, 3, 4]);
    }

    #[test]
    fn split_keeps_order_and_prunes_vertices() {
        let mut u = unit();
        let g = u.split_off_fraction(0.5);
        assert_eq!(g.cells.iter().map(|c| c.id).collect::<Vec<_>>(), vec![3]);
        assert_eq!(g.vertex_ids, vec![0, 1, 2, 4]);
        assert_eq!(u.cells.iter().map(|c| c.id).collect::<Vec<_>>(), vec![7, 9]);
        assert_eq!(u.global_ids(1), [1, 2, 3, 4]);
        assert_eq!(g.global_ids(0), [4, 1, 2, 0]);
        assert_eq!(g.positions[3], [1.0, 1.0, 1.0]);
        let mut one = unit();
        assert_eq!(one.split_off_third().len(), 1);
        assert_eq!(one.len(), 2);
    }

    #[test]
    fn rejects_bad_units() {
        let mut u = unit();
        u.scalars[0] = f32::NAN;
        assert!(matches!(
            WorkUnit::decode(&u.encode()),
            Err(WorkError::NonFinite(0))
        ));
        let mut u = unit();
        u.cells[0].v[0] = 99;
        assert!(matches!(
            u.validate(),
            Err(WorkError::CellVertex { cell: 7 })
        ));
        // A collapsed cell (a repeated vertex) is the mesh's own business.
        let mut u = unit();
        u.cells[0].v[1] = u.cells[0].v[0];
        assert_eq!(WorkUnit::decode(&u.encode()), Ok(u));
        let mut u = unit();
        u.cells[1].id = 7;
        assert_eq!(u.validate(), Err(WorkError::DuplicateCell(7)));
        let mut u = unit();
        u.vertex_ids.swap(0, 1);
        assert!(u.validate().is_err());
        assert!(unit().validate_against(4, 100).is_err());
        assert!(unit().validate_against(5, 9).is_err());
        assert!(unit().validate_against(5, 10).is_ok());
        let mut b = unit().encode();
        b.push(0);
        assert!(WorkUnit::decode(&b).is_err(), "trailing bytes");
        // A huge length prefix must fail, not allocate.
        let mut b = vec![0xff; 8];
        b.extend_from_slice(&[1, 2, 3]);
        assert!(WorkUnit::decode(&b).is_err());
    }
}
