//! How a node holds its cells: 32 bytes a cell over a table of the
//! vertices its work units brought, instead of a 104-byte
//! [`CellRecord`] a cell.
//!
//! A node keeps every cell it was given for the whole frame (processed
//! ones first), so the bytes a cell costs are the node's memory: on 20 M
//! tetrahedra in 8 pieces a worker keeps about a million cells. A
//! [`NodeCell`] holds what ordering, the ERT tests, release ordering and
//! giving work away read (nearest depth, cell id, pixel range) and the
//! cell's four vertices as indices into the node's [`VertexTable`];
//! [`VertexTable::record`] rebuilds the [`CellRecord`] scan conversion
//! takes, as the single-machine renderer rebuilds a tile's records from its
//! bins. The record is the same one, so the image is the same bit for bit.

use crate::render::cell::bin::{order_key, CellRecord, Range16};

/// One cell a node holds. See the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct NodeCell {
    /// Nearest depth of its vertices.
    pub near: f32,
    /// Global cell id.
    pub cell: u32,
    /// Covered pixel range.
    range16: Range16,
    /// Its vertices, as indices into the node's [`VertexTable`].
    v: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<NodeCell>() == 32);

impl NodeCell {
    /// The compact form of `rec`, whose vertices are `v` in the table.
    #[inline]
    pub fn new(rec: &CellRecord, v: [u32; 4]) -> NodeCell {
        NodeCell {
            near: rec.near,
            cell: rec.cell,
            range16: Range16::new(rec.range),
            v,
        }
    }

    /// Covered pixel range, inclusive: `i0, i1, j0, j1`.
    #[inline(always)]
    pub fn range(&self) -> [u32; 4] {
        self.range16.get()
    }

    /// Its vertices' indices in the table.
    #[inline]
    pub fn v(&self) -> [u32; 4] {
        self.v
    }

    /// Sort key for front-to-back order: nearest depth, then cell id
    /// ([`CellRecord::order_key`]).
    #[inline]
    pub fn order_key(&self) -> u64 {
        order_key(self.near, self.cell)
    }
}

/// One vertex as scan conversion reads it: the three values a cell's
/// record gathers, side by side (one cache line holds three vertices; the
/// cells are scanned in depth order, so their vertices are read at random).
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct TableVertex {
    /// Projected position (screen space or camera frame).
    pub pos: [f32; 3],
    /// Normalised scalar.
    pub s: f32,
    /// Global vertex id.
    pub id: u32,
}

/// The vertices of a node's cells, appended unit by unit (a vertex two
/// units bring is held twice; both copies are equal).
#[derive(Debug, Clone, Default)]
pub struct VertexTable {
    /// The vertices.
    pub v: Vec<TableVertex>,
    /// World position, for giving cells away with their vertices
    /// (partitioned data; empty with replicated data, whose cells travel
    /// as ids).
    pub world: Vec<[f64; 3]>,
}

impl VertexTable {
    /// Vertices held.
    pub fn len(&self) -> usize {
        self.v.len()
    }

    /// The record scan conversion takes for `c`.
    #[inline]
    pub fn record(&self, c: &NodeCell) -> CellRecord {
        let v = c.v.map(|l| self.v[l as usize]);
        CellRecord {
            near: c.near,
            cell: c.cell,
            range: c.range(),
            ids: v.map(|x| x.id),
            pos: v.map(|x| x.pos),
            s: v.map(|x| x.s),
        }
    }

    /// Global vertex ids of `c`.
    #[inline]
    pub fn global_ids(&self, c: &NodeCell) -> [u32; 4] {
        c.v.map(|l| self.v[l as usize].id)
    }

    /// Asks the processor to fetch `c`'s vertices (a few cells before their
    /// record is built: the cells are scanned in depth order, so their
    /// vertices are read at random over the table; x86-64 only, a hint).
    #[inline(always)]
    pub fn prefetch(&self, c: &NodeCell) {
        #[cfg(target_arch = "x86_64")]
        for l in c.v {
            if let Some(x) = self.v.get(l as usize) {
                // SAFETY: a prefetch of a valid reference's address: a hint
                // that reads nothing and cannot fault.
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                        (x as *const TableVertex).cast(),
                    )
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_node_cell_rebuilds_the_record_it_was_made_of() {
        let rec = CellRecord {
            near: 1.5,
            cell: 42,
            range: [3, 9, 65535, 65535],
            ids: [7, 9, 11, 13],
            pos: [
                [0.5, 1.5, 2.0],
                [1.0, 2.0, 3.0],
                [4.0, 0.0, 1.5],
                [2.5, 3.5, 4.5],
            ],
            s: [0.0, 0.25, 0.5, 1.0],
        };
        let mut t = VertexTable::default();
        for k in [2usize, 0, 3, 1] {
            t.v.push(TableVertex {
                pos: rec.pos[k],
                s: rec.s[k],
                id: rec.ids[k],
            });
        }
        let c = NodeCell::new(&rec, [1, 3, 0, 2]);
        let back = t.record(&c);
        assert_eq!(back.ids, rec.ids);
        assert_eq!(back.pos, rec.pos);
        assert_eq!(back.s, rec.s);
        assert_eq!(back.range, rec.range);
        assert_eq!((back.near, back.cell), (rec.near, rec.cell));
        assert_eq!(c.order_key(), rec.order_key());
        assert_eq!(t.global_ids(&c), rec.ids);
    }
}
