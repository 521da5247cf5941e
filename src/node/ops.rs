//! Operation counts: what a node did, the input of the compute-time cost
//! model ([`super::cost`]). Every counter is a number of elementary
//! operations of one kind; their unit costs are a [`super::CostProfile`].

use serde::{Deserialize, Serialize};

/// Counts of the operations a node performed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct OpCounts {
    /// Vertices transformed to screen space (when work arrives).
    pub vertices_projected: u64,
    /// Cells received in work units and culled or turned into records.
    pub cells_received: u64,
    /// Of those, culled on arrival (empty scalar interval, off screen, no pixel centre).
    pub cells_culled: u64,
    /// Cells tested against the ERT table before scan conversion.
    pub cells_tested: u64,
    /// Cells skipped by ERT.
    pub cells_skipped_ert: u64,
    /// Cells scan-converted (face set-up done; the paper's "projected").
    pub cells_projected: u64,
    /// Of those, degenerate (no ray stretch of positive length).
    pub cells_degenerate: u64,
    /// Pixel centres found inside a cell: in orthographic views the covered
    /// ones (the scalar span scan and the vectorised box scan test
    /// different candidate sets but count alike, so the virtual clock does
    /// not depend on the CPU), in perspective every one tested.
    pub pixels_tested: u64,
    /// Ray segments generated (integrated and inserted).
    pub segments_generated: u64,
    /// Merges done by partial composition on insertion.
    pub segments_merged: u64,
    /// Exact integrator: pieces integrated of the segments that cross
    /// transfer-function control points or need sub-steps (one a piece
    /// between two points; segments within one piece are not counted).
    #[serde(default)]
    pub segment_pieces: u64,
    /// ERT update: pixel lists walked (pixels whose list changed).
    pub lists_walked: u64,
    /// ERT update: list entries visited while computing termination depths.
    pub list_entries_walked: u64,
    /// ERT update: table entries recomputed.
    pub table_entries_updated: u64,
    /// ERT update: per-pixel depths read while recomputing entries.
    pub table_pixels_read: u64,
    /// Shared-table entries merged (manager's table applied, or tables merged).
    pub shared_entries_merged: u64,
    /// Cells packed into or unpacked from work units given away or taken.
    pub work_cells_moved: u64,
    /// Cell ids written into or read from id units (replicated data,
    /// [`super::replica`]).
    pub cell_ids_moved: u64,
    /// Cells keyed and moved by a release reorder ([`super::release`]).
    #[serde(default)]
    pub cells_reordered: u64,
    /// Leaves keyed (depth and pixel of their centre) to compute a global
    /// front-to-back schedule ([`super::schedule`]); priced as a cell record.
    #[serde(default)]
    pub units_keyed: u64,
}

impl OpCounts {
    /// Adds `o` to `self`.
    pub fn add(&mut self, o: &OpCounts) {
        macro_rules! add {
            ($($f:ident),*) => { $( self.$f += o.$f; )* };
        }
        add!(
            vertices_projected,
            cells_received,
            cells_culled,
            cells_tested,
            cells_skipped_ert,
            cells_projected,
            cells_degenerate,
            pixels_tested,
            segments_generated,
            segments_merged,
            segment_pieces,
            lists_walked,
            list_entries_walked,
            table_entries_updated,
            table_pixels_read,
            shared_entries_merged,
            work_cells_moved,
            cell_ids_moved,
            cells_reordered,
            units_keyed
        );
    }

    /// `self + o`.
    pub fn plus(mut self, o: &OpCounts) -> OpCounts {
        self.add(o);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn add_is_fieldwise() {
        let a = OpCounts {
            pixels_tested: 3,
            work_cells_moved: 1,
            ..Default::default()
        };
        let b = a.plus(&a);
        assert_eq!(b.pixels_tested, 6);
        assert_eq!(b.work_cells_moved, 2);
        assert_eq!(b.cells_tested, 0);
    }
}
