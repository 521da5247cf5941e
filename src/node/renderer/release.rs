//! Release ordering on a node ([`crate::node::release`]): the map this node
//! publishes, the reply it applies, and the scan order by release key.

use std::collections::HashMap;

use super::cells::NodeCell;
use super::NodeRenderer;
use crate::node::ops::OpCounts;
use crate::node::release::{BlockMap, ReleaseMap, ReleaseReply, ReleaseShare, BUCKETS};
use crate::node::table::TableError;

/// A node's release-ordering state.
#[derive(Debug, Clone)]
pub(super) struct Release {
    blocks: BlockMap,
    /// `lag` as a rank code (fraction of the frame × 65535).
    lag: u16,
    /// The manager's reply, once applied.
    map: Option<ReleaseMap>,
    /// Per cell id, its scan bucket (only once `map` is set).
    bucket: HashMap<u32, u16>,
}

/// Rank code of position `i` of `n`.
fn rank_code(i: usize, n: usize) -> u16 {
    ((i as u64 * 65535) / n.max(1) as u64) as u16
}

impl NodeRenderer {
    /// Turns release ordering on (per-pixel sharing must be on: depths are
    /// coded with its [`crate::node::pixel_share::DepthQuant`]): blocks of
    /// `block` pixels, release `lag` as a fraction of the frame.
    pub fn enable_release(&mut self, block: u32, lag: f32) {
        if self.pixel_levels.is_none() || self.release.is_some() {
            return;
        }
        self.release = Some(Release {
            blocks: BlockMap::new(self.view.width, self.view.height, block),
            lag: (lag.clamp(0.0, 1.0) * 65535.0) as u16,
            map: None,
            bucket: HashMap::new(),
        });
    }

    /// The block grid of release ordering, if on.
    pub fn release_blocks(&self) -> Option<BlockMap> {
        self.release.as_ref().map(|r| r.blocks)
    }

    /// This node's release share ([`ReleaseShare`]): per block its
    /// unprocessed cells cover, the nearest depth code and the smallest
    /// rank code. Cost: `table_pixels_read` per block of each cell's range,
    /// `shared_entries_merged` per block coded. `None` if release ordering
    /// is off.
    pub fn take_release_share(&mut self) -> Option<(Vec<u8>, OpCounts)> {
        let rel = self.release.as_ref()?;
        let quant = self.pixel_levels.as_ref()?.quant;
        let bm = rel.blocks;
        let mut fz = vec![u16::MAX; bm.len()];
        let mut rk = vec![u16::MAX; bm.len()];
        let mut ops = OpCounts::default();
        let rest = &self.records[self.next..];
        for (i, c) in rest.iter().enumerate() {
            let (z, r) = (quant.up(c.near), rank_code(i, rest.len()));
            let br = bm.blocks(c.range());
            for by in br[2]..=br[3] {
                for bx in br[0]..=br[1] {
                    let b = (by * bm.bw + bx) as usize;
                    fz[b] = fz[b].min(z);
                    rk[b] = rk[b].min(r);
                    ops.table_pixels_read += 1;
                }
            }
        }
        let blocks: Vec<(u32, u16, u16)> = (0..bm.len())
            .filter(|&b| rk[b] != u16::MAX)
            .map(|b| (b as u32, fz[b], rk[b]))
            .collect();
        ops.shared_entries_merged = blocks.len() as u64;
        self.totals.add(&ops);
        let s = ReleaseShare {
            dims: (bm.bw, bm.bh),
            blocks,
        };
        Some((s.encode(), ops))
    }

    /// Applies the manager's [`ReleaseReply`]: keys every unprocessed cell
    /// by `max(r, T + lag)` and reorders the queue by key bucket, nearest
    /// first inside a bucket (a stable bucket sort of the near-ordered
    /// queue). Cost: `shared_entries_merged` per pair decoded,
    /// `table_pixels_read` per block looked up, `cells_reordered` per cell.
    pub fn apply_release(&mut self, bytes: &[u8]) -> Result<OpCounts, TableError> {
        let Some(rel) = self.release.as_mut() else {
            return Err(TableError::Length(bytes.len()));
        };
        let Some(quant) = self.pixel_levels.as_ref().map(|p| p.quant) else {
            return Err(TableError::Length(bytes.len()));
        };
        let bm = rel.blocks;
        let reply = ReleaseReply::decode(bytes, (bm.bw, bm.bh))?;
        let mut ops = OpCounts {
            shared_entries_merged: reply.blocks.iter().map(|(_, e)| e.len() as u64).sum(),
            ..Default::default()
        };
        let map = reply.into_map();
        let n = self.records.len() - self.next;
        let rest: Vec<NodeCell> = self.records.drain(self.next..).collect();
        let mut keyed: Vec<(u16, NodeCell)> = Vec::with_capacity(n);
        for (i, c) in rest.into_iter().enumerate() {
            let (t, seen) = map.release(bm.blocks(c.range()), quant.up(c.near));
            ops.table_pixels_read += seen;
            let key = if t == 0 {
                rank_code(i, n)
            } else {
                rank_code(i, n).max(t.saturating_add(rel.lag))
            };
            let b = ((key as u32 * BUCKETS) >> 16) as u16;
            rel.bucket.insert(c.cell, b);
            keyed.push((b, c));
        }
        // Stable: the queue was nearest-first, so it stays so inside a bucket.
        keyed.sort_by_key(|e| e.0);
        self.records.extend(keyed.into_iter().map(|e| e.1));
        ops.cells_reordered = n as u64;
        rel.map = Some(map);
        self.totals.add(&ops);
        Ok(ops)
    }

    /// Whether the queue is in release order (the reply has been applied).
    pub fn release_ordered(&self) -> bool {
        self.release.as_ref().is_some_and(|r| r.map.is_some())
    }

    /// Release order for cells just added at `records[from..]` (help, DLB):
    /// keyed by `T + lag` (0 if not covered), then the whole queue sorted
    /// by (bucket, nearest first). Counts `cells_reordered` per cell added.
    pub(super) fn sort_released(&mut self, from: usize, ops: &mut OpCounts) {
        let Some(rel) = self.release.as_mut() else {
            return;
        };
        let (Some(map), Some(quant)) = (
            rel.map.as_ref(),
            self.pixel_levels.as_ref().map(|p| p.quant),
        ) else {
            return;
        };
        for c in &self.records[from..] {
            let (t, seen) = map.release(rel.blocks.blocks(c.range()), quant.up(c.near));
            ops.table_pixels_read += seen;
            let key = if t == 0 { 0 } else { t.saturating_add(rel.lag) };
            rel.bucket
                .insert(c.cell, ((key as u32 * BUCKETS) >> 16) as u16);
        }
        ops.cells_reordered += (self.records.len() - from) as u64;
        let bucket = &rel.bucket;
        self.records[self.next..]
            .sort_by_key(|c| (bucket.get(&c.cell).copied().unwrap_or(0), c.order_key()));
    }
}
