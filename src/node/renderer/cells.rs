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

use crate::render::cell::bin::{near_key, CellRecord};

/// One cell a node holds. See the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct NodeCell {
    /// Nearest depth of its vertices.
    pub near: f32,
    /// Global cell id.
    pub cell: u32,
    /// Covered pixel range, inclusive (`i0, i1, j0, j1`; an image side is
    /// at most 65536 pixels).
    range16: [u16; 4],
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
            range16: rec.range.map(|r| r.min(u16::MAX as u32) as u16),
            v,
        }
    }

    /// Covered pixel range, inclusive: `i0, i1, j0, j1`.
    #[inline(always)]
    pub fn range(&self) -> [u32; 4] {
        self.range16.map(u32::from)
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
        (near_key(self.near) as u64) << 32 | self.cell as u64
    }
}

/// The vertices of a node's cells, appended unit by unit (a vertex two
/// units bring is held twice; both copies are equal).
#[derive(Debug, Clone, Default)]
pub struct VertexTable {
    /// Global vertex id.
    pub ids: Vec<u32>,
    /// Projected position (screen space or camera frame), as scan
    /// conversion reads it.
    pub pos: Vec<[f32; 3]>,
    /// Normalised scalar.
    pub s: Vec<f32>,
    /// World position, for giving cells away with their vertices
    /// (partitioned data; empty with replicated data, whose cells travel
    /// as ids).
    pub world: Vec<[f64; 3]>,
}

impl VertexTable {
    /// Vertices held.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// The record scan conversion takes for `c`.
    #[inline]
    pub fn record(&self, c: &NodeCell) -> CellRecord {
        let v = c.v.map(|l| l as usize);
        CellRecord {
            near: c.near,
            cell: c.cell,
            range: c.range(),
            ids: v.map(|l| self.ids[l]),
            pos: v.map(|l| self.pos[l]),
            s: v.map(|l| self.s[l]),
        }
    }

    /// Global vertex ids of `c`.
    #[inline]
    pub fn global_ids(&self, c: &NodeCell) -> [u32; 4] {
        c.v.map(|l| self.ids[l as usize])
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
            t.ids.push(rec.ids[k]);
            t.pos.push(rec.pos[k]);
            t.s.push(rec.s[k]);
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
