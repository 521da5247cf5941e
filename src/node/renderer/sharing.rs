//! The ERT information a node shares: per-pixel opacity levels for the
//! pyramid structure ([`crate::node::pixel_share`]) and per-block level
//! masks for the flat structure's level sharing ([`crate::node::levels`]),
//! and the list walks that compute them.

use super::NodeRenderer;
use crate::base::segment::Segment;
use crate::node::levels::{level_alphas, BlockGrid, LevelDelta, LevelMask};
use crate::node::ops::OpCounts;
use crate::node::pixel_share::{DepthQuant, NodePixelLevels, PixelDepths};
use crate::node::shard_map::ShardMap;
use crate::node::table::TableError;

impl NodeRenderer {
    /// Turns on per-pixel level sharing ([`crate::node::pixel_share`]; with weak
    /// sharing and `NodeErt::pixel_sharing`): table updates also keep the
    /// per-pixel level depths, [`NodeRenderer::take_pixel_levels`] gives the
    /// pixels that changed, with depths coded by `quant`.
    pub fn enable_pixel_sharing(&mut self, quant: DepthQuant) {
        let e = self.opts.ert;
        if !e.pixel_sharing() || self.pixel_levels.is_some() {
            return;
        }
        let (w, h) = (self.view.width, self.view.height);
        let l = e.share_levels.clamp(1, 16) as usize;
        self.pixel_levels = Some(NodePixelLevels::new(w, h, e.threshold(), l, quant));
    }

    /// The frame's depth range width (per-pixel sharing's codes), if on.
    pub fn depth_span(&self) -> Option<f32> {
        self.pixel_levels.as_ref().map(|p| p.quant.span())
    }

    /// Image size and level count of per-pixel level sharing, if on.
    pub fn pixel_share_shape(&self) -> Option<(u32, u32, usize)> {
        self.pixel_levels
            .as_ref()
            .map(|p| (self.view.width, self.view.height, p.levels()))
    }

    /// Per-pixel level sharing with a sharded manager: which shard owns
    /// which screen tile (call before the first step). No effect if
    /// per-pixel sharing is off.
    pub fn set_manager_shards(&mut self, map: ShardMap) {
        if let Some(pl) = self.pixel_levels.as_mut() {
            pl.set_shards(map);
        }
    }

    /// Per-pixel level sharing: per manager shard, whether it owns a tile
    /// under this node's footprint (shard 0, the manager, always). `None`
    /// if per-pixel sharing is off.
    pub fn manager_shards_touched(&self) -> Option<Vec<bool>> {
        let pl = self.pixel_levels.as_ref()?;
        Some(pl.shards().touched(self.footprint))
    }

    /// Per-pixel level sharing: the pixels of manager shard `shard`'s tiles
    /// whose level depths changed since the last call for that shard,
    /// encoded ([`crate::node::pixel_share::PixelLevels::encode`]); packing
    /// counted as `shared_entries_merged` (one per code). `None` if
    /// per-pixel sharing is off.
    pub fn take_pixel_levels(&mut self, shard: usize) -> Option<(Vec<u8>, OpCounts)> {
        let (w, h) = (self.view.width, self.view.height);
        let footprint = self.footprint;
        let pl = self.pixel_levels.as_mut()?;
        let (d, packed) = pl.take(shard, w, h, footprint);
        let ops = OpCounts {
            shared_entries_merged: packed,
            ..Default::default()
        };
        self.totals.add(&ops);
        Some((d.encode(), ops))
    }

    /// Applies the manager's certified per-pixel depths
    /// ([`crate::node::pixel_share::PixelDepths`]): each pixel's depth becomes the
    /// min of its own and the certified one, and the pyramid (and table) are
    /// rebuilt over the pixels that changed. Cost: one `shared_entries_merged`
    /// per entry received, plus the rebuild.
    pub fn apply_pixel_depths(&mut self, bytes: &[u8]) -> Result<OpCounts, TableError> {
        let (w, h) = (self.view.width, self.view.height);
        let Some(pl) = self.pixel_levels.as_ref() else {
            return Err(TableError::Length(bytes.len()));
        };
        let d = PixelDepths::decode(bytes, w, h)?;
        let flat = self.flat_table();
        let mut ops = OpCounts {
            shared_entries_merged: d.pixels.len() as u64,
            ..Default::default()
        };
        for &(p, c) in &d.pixels {
            let z = pl.quant.value(c);
            let p = p as usize;
            if z < self.depth[p] {
                self.depth[p] = z;
                let (x, y) = (p as u32 % w, p as u32 / w);
                if flat {
                    self.table.mark(x, y);
                }
                if let Some(py) = self.pyramid.as_mut() {
                    py.mark(x, y);
                }
            }
        }
        if flat {
            self.table.rebuild(&self.depth, &mut ops);
        }
        if let Some(py) = self.pyramid.as_mut() {
            ops.table_pixels_read += py.rebuild_counted(&self.depth);
        }
        self.totals.add(&ops);
        Ok(ops)
    }

    /// Turns on level sharing (with weak sharing and
    /// `NodeErt::level_sharing`): from now on table updates also keep
    /// per-pixel and per-block opacity-level depths, and
    /// [`NodeRenderer::take_level_delta`] gives the blocks that changed.
    /// Call before the first step.
    pub fn enable_level_sharing(&mut self) {
        let e = self.opts.ert;
        if !e.level_sharing() || self.levels.is_some() {
            return;
        }
        let (w, h) = (self.view.width, self.view.height);
        let grid = BlockGrid::new(w, h, e.divisions, e.share_sub as u32);
        let l = e.share_levels.clamp(1, 16) as usize;
        self.levels = Some(NodeLevels {
            grid,
            alphas: level_alphas(e.threshold(), l),
            pix: vec![f32::INFINITY; (w * h) as usize * l],
            block: vec![None; grid.len() * l],
            dirty_flag: vec![false; grid.len()],
            dirty: Vec::new(),
            unsent_flag: vec![false; grid.len()],
            unsent: Vec::new(),
        });
    }

    /// The block grid and level count of level sharing, if on.
    pub fn level_grid(&self) -> Option<(BlockGrid, usize)> {
        self.levels.as_ref().map(|l| (l.grid, l.alphas.len()))
    }

    /// Level sharing: the blocks whose level masks changed since the last
    /// call, encoded ([`LevelDelta::encode`]); packing counted as
    /// `shared_entries_merged` (one per mask). `None` if level sharing is off.
    pub fn take_level_delta(&mut self) -> Option<(Vec<u8>, OpCounts)> {
        let lv = self.levels.as_mut()?;
        let l = lv.alphas.len();
        let mut ids = std::mem::take(&mut lv.unsent);
        ids.sort_unstable();
        let (nbx, nby) = lv.grid.dims();
        let blocks: Vec<(u32, Vec<Option<LevelMask>>)> = ids
            .iter()
            .map(|&b| {
                lv.unsent_flag[b as usize] = false;
                (b, lv.block[b as usize * l..(b as usize + 1) * l].to_vec())
            })
            .collect();
        let ops = OpCounts {
            shared_entries_merged: blocks
                .iter()
                .map(|(_, v)| v.iter().flatten().count() as u64)
                .sum(),
            ..Default::default()
        };
        self.totals.add(&ops);
        let d = LevelDelta {
            nbx: nbx as u16,
            nby: nby as u16,
            levels: l as u8,
            blocks,
        };
        Some((d.encode(&lv.grid), ops))
    }
}

/// Per-pixel and per-block opacity-level depths for level sharing
/// ([`crate::node::levels`]).
#[derive(Debug, Clone)]
pub(super) struct NodeLevels {
    pub(super) grid: BlockGrid,
    pub(super) alphas: Vec<f32>,
    /// `[pixel * L + l]`, cached, only ever decreasing.
    pub(super) pix: Vec<f32>,
    /// `[block * L + l]`: the block's pixels that reached level `l`, and
    /// their deepest depth.
    pub(super) block: Vec<Option<LevelMask>>,
    pub(super) dirty_flag: Vec<bool>,
    pub(super) dirty: Vec<u32>,
    pub(super) unsent_flag: Vec<bool>,
    pub(super) unsent: Vec<u32>,
}

impl NodeLevels {
    /// Recomputes the dirty blocks' level depths (max over their pixels);
    /// blocks whose values changed are queued for the next share.
    pub(super) fn rebuild(&mut self, w: u32, ops: &mut OpCounts) {
        let l = self.alphas.len();
        for &b in &self.dirty {
            let b = b as usize;
            self.dirty_flag[b] = false;
            let (x0, x1, y0, y1) = self.grid.rect(b);
            let words = self.grid.words();
            let mut m: Vec<LevelMask> = (0..l)
                .map(|_| LevelMask {
                    bits: vec![0; words],
                    depth: f32::NEG_INFINITY,
                })
                .collect();
            let mut i = 0;
            for y in y0..y1 {
                for x in x0..x1 {
                    let p = (y * w + x) as usize;
                    for (mv, &v) in m.iter_mut().zip(&self.pix[p * l..(p + 1) * l]) {
                        if v.is_finite() {
                            mv.bits[i / 64] |= 1 << (i % 64);
                            mv.depth = mv.depth.max(v);
                        }
                    }
                    i += 1;
                }
            }
            ops.table_entries_updated += 1;
            ops.table_pixels_read += ((x1 - x0) * (y1 - y0)) as u64 * l as u64;
            let new: Vec<Option<LevelMask>> = m
                .into_iter()
                .map(|m| m.depth.is_finite().then_some(m))
                .collect();
            let old = &mut self.block[b * l..(b + 1) * l];
            if old != &new[..] {
                old.clone_from_slice(&new);
                if !self.unsent_flag[b] {
                    self.unsent_flag[b] = true;
                    self.unsent.push(b as u32);
                }
            }
        }
        self.dirty.clear();
    }
}

/// Walks `list` front to back until the last of `alphas` is reached; per
/// level, lowers `cached[l]` to the `z_back` of the segment where the
/// accumulated opacity first reaches `alphas[l]`. Returns the entries
/// visited and whether any cached value changed.
pub fn level_depths_counted(list: &[Segment], alphas: &[f32], cached: &mut [f32]) -> (usize, bool) {
    let mut acc = 0.0f32;
    let mut j = 0;
    let mut changed = false;
    let mut walked = list.len();
    for (k, s) in list.iter().enumerate() {
        acc += (1.0 - acc) * s.rgba.a;
        while j < alphas.len() && acc >= alphas[j] {
            if s.z_back < cached[j] {
                cached[j] = s.z_back;
                changed = true;
            }
            j += 1;
        }
        if j == alphas.len() {
            walked = k + 1;
            break;
        }
    }
    (walked, changed)
}

/// [`crate::render::cell::ert::termination_depth`], and the number of list
/// entries visited.
pub fn termination_depth_counted(list: &[Segment], threshold: f32) -> (f32, usize) {
    let mut acc = 0.0f32;
    for (k, s) in list.iter().enumerate() {
        acc += (1.0 - acc) * s.rgba.a;
        if acc >= threshold {
            return (s.z_back, k + 1);
        }
    }
    (f32::INFINITY, list.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::segment::Rgba;
    use crate::render::cell::ert::termination_depth;

    #[test]
    fn counted_depth_agrees() {
        let seg = |zf: f32, a: f32| Segment {
            z_front: zf,
            z_back: zf + 1.0,
            rgba: Rgba { rgb: [a; 3], a },
        };
        let l = [seg(0.0, 0.5), seg(2.0, 0.5), seg(4.0, 0.8)];
        for thr in [0.3, 0.6, 0.9, 0.99] {
            assert_eq!(
                termination_depth_counted(&l, thr).0,
                termination_depth(&l, thr)
            );
        }
        assert_eq!(termination_depth_counted(&l, 0.6), (3.0, 2));
        assert_eq!(termination_depth_counted(&l, 0.99).1, 3);
    }
}
