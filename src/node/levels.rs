//! Opacity-level sharing: ERT information that composes across nodes.
//!
//! The paper's manager keeps, per entry, the minimum `deepest` over the
//! nodes whose entry is terminated. That only helps when **one** node's own
//! segments reach the threshold over a whole entry. On data split into
//! spatially coherent pieces a ray usually crosses several nodes' pieces,
//! none of which is opaque enough alone: `examples/share_bound.rs` measures
//! that even with the nodes scanning in the global front-to-back order and
//! tables exchanged instantly, the paper's rule skips only 64 % (view B) and
//! 70 % (view A) of what the sequential renderer skips.
//!
//! Here a node shares, for each **block** (an entry cut into `sub x sub`
//! blocks) and each of `L` **opacity levels** `a_l = 1 - (1 - thr)^(l / L)`
//! (`a_L = thr`), a [`LevelMask`]: the set of the block's pixels whose own
//! segments reached `a_l`, and the deepest depth at which they did.
//! Transmittances multiply over disjoint segments, and the segments of
//! different nodes are disjoint (cells are), so at depth `z` a pixel's
//! transmittance over the union of all nodes' segments is at most
//! `prod_k (1 - thr)^(l_k / L)`, `l_k` being the number of node `k`'s masks
//! that hold the pixel with a depth `<= z`; the pixel is terminated (at most
//! `1 - thr`) as soon as `sum_k l_k >= L`. Counting one unit per such
//! (node, level) mask, the smallest `z` for a pixel is the **`L`-th smallest
//! depth** among the masks holding it, and a block's certified `deepest` is
//! the max of that over its pixels ([`combine_masks`]): opacity adds up
//! across nodes in depth (rays crossing several nodes' pieces, view B) and
//! pixels terminated by different nodes add up across space (entries cut by
//! node boundaries, view A). An entry's `deepest` is the max over its blocks.
//! It is a valid certificate with the same error bound as the paper's table,
//! up to the `f32` rounding of the levels (the per-pixel test `acc >= a_l`
//! is `f32`, as the sequential one is). Every mask a node ever sent stays a
//! valid certificate (segments are only added), so the manager may replace
//! a node's masks by newer ones and keep per block the min of everything it
//! combined.
//!
//! Nodes send only the blocks whose masks changed since their last share
//! ([`LevelDelta`]); the manager keeps every node's latest masks, recombines
//! the changed blocks and replies with the usual per-entry
//! [`super::SharedTable`].

use super::table::TableError;

/// The block grid over the image: each `ex x ey`-pixel entry cut into
/// blocks of `ceil(ex / sub) x ceil(ey / sub)` pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlockGrid {
    /// Image size.
    pub size: (u32, u32),
    /// Entry size in pixels.
    pub entry: (u32, u32),
    /// Entries per row and column.
    pub n: (u32, u32),
    /// Block size in pixels.
    pub block: (u32, u32),
    /// Blocks per entry along each axis.
    pub per_entry: (u32, u32),
}

impl BlockGrid {
    /// The grid of a `width x height` image with `D = d` entries per axis,
    /// each cut into `sub x sub` blocks.
    pub fn new(width: u32, height: u32, d: u32, sub: u32) -> BlockGrid {
        let entry = super::table::entry_px(width, height, d);
        let n = (width.div_ceil(entry.0), height.div_ceil(entry.1));
        let sub = sub.max(1);
        let block = (entry.0.div_ceil(sub).max(1), entry.1.div_ceil(sub).max(1));
        let per_entry = (entry.0.div_ceil(block.0), entry.1.div_ceil(block.1));
        BlockGrid {
            size: (width, height),
            entry,
            n,
            block,
            per_entry,
        }
    }

    /// Blocks per row and column.
    pub fn dims(&self) -> (u32, u32) {
        (self.n.0 * self.per_entry.0, self.n.1 * self.per_entry.1)
    }

    /// Number of blocks.
    pub fn len(&self) -> usize {
        let (a, b) = self.dims();
        (a * b) as usize
    }

    /// Whether the grid has no blocks.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Block of pixel `(x, y)`.
    #[inline]
    pub fn block_of(&self, x: u32, y: u32) -> usize {
        let bx = (x / self.entry.0) * self.per_entry.0 + (x % self.entry.0) / self.block.0;
        let by = (y / self.entry.1) * self.per_entry.1 + (y % self.entry.1) / self.block.1;
        (by * self.dims().0 + bx) as usize
    }

    /// Pixel rectangle `[x0, x1) x [y0, y1)` of block `b` (empty for blocks
    /// past the image's edge).
    pub fn rect(&self, b: usize) -> (u32, u32, u32, u32) {
        let nbx = self.dims().0;
        let (bx, by) = (b as u32 % nbx, b as u32 / nbx);
        let x0 = (bx / self.per_entry.0) * self.entry.0 + (bx % self.per_entry.0) * self.block.0;
        let y0 = (by / self.per_entry.1) * self.entry.1 + (by % self.per_entry.1) * self.block.1;
        let ex1 = ((bx / self.per_entry.0) + 1) * self.entry.0;
        let ey1 = ((by / self.per_entry.1) + 1) * self.entry.1;
        let x1 = (x0 + self.block.0).min(ex1).min(self.size.0);
        let y1 = (y0 + self.block.1).min(ey1).min(self.size.1);
        (x0.min(x1), x1, y0.min(y1), y1)
    }

    /// The entry block `b` lies in.
    pub fn entry_of(&self, b: usize) -> usize {
        let nbx = self.dims().0;
        let (bx, by) = (b as u32 % nbx, b as u32 / nbx);
        ((by / self.per_entry.1) * self.n.0 + bx / self.per_entry.0) as usize
    }

    /// The non-empty blocks of entry `e`.
    pub fn blocks_of(&self, e: usize) -> impl Iterator<Item = usize> + '_ {
        let (ex, ey) = (e as u32 % self.n.0, e as u32 / self.n.0);
        let nbx = self.dims().0;
        (0..self.per_entry.1).flat_map(move |j| {
            (0..self.per_entry.0).filter_map(move |i| {
                let b = ((ey * self.per_entry.1 + j) * nbx + ex * self.per_entry.0 + i) as usize;
                let (x0, x1, y0, y1) = self.rect(b);
                (x1 > x0 && y1 > y0).then_some(b)
            })
        })
    }
}

/// The opacity levels `a_l = 1 - (1 - thr)^(l / L)`, `l = 1..=L`, with
/// `a_L = thr` exactly.
pub fn level_alphas(threshold: f32, levels: usize) -> Vec<f32> {
    let levels = levels.max(1);
    (1..=levels)
        .map(|l| {
            if l == levels {
                threshold
            } else {
                1.0 - (1.0 - threshold as f64).powf(l as f64 / levels as f64) as f32
            }
        })
        .collect()
}

/// The smallest depth at which a block is certified terminated from all
/// nodes' level values (each node's `L` values for the block, nondecreasing,
/// `+inf` where not reached): the `L`-th smallest value overall (`+inf` if
/// fewer than `L` are finite). See the module docs.
pub fn combine_block<'a>(values: impl Iterator<Item = &'a [f32]>, levels: usize) -> f32 {
    let mut v: Vec<f32> = values
        .flat_map(|s| s.iter().copied())
        .filter(|d| d.is_finite())
        .collect();
    if v.len() < levels || levels == 0 {
        return f32::INFINITY;
    }
    let (_, nth, _) = v.select_nth_unstable_by(levels - 1, |a, b| a.total_cmp(b));
    *nth
}

/// Pixels of a block reached at one level, and the deepest of their depths.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelMask {
    /// One bit per pixel of the block (row-major over its rectangle), LSB
    /// first in 64-bit words: the pixels whose own opacity reached the level.
    pub bits: Vec<u64>,
    /// Max over those pixels of the depth where they reached it.
    pub depth: f32,
}

/// The blocks whose level information changed since a node's last share.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LevelDelta {
    /// Blocks per row.
    pub nbx: u16,
    /// Blocks per column.
    pub nby: u16,
    /// Levels `L` (1..=16).
    pub levels: u8,
    /// Changed blocks, ascending; per block `L` masks (`None`: no pixel
    /// reached the level).
    pub blocks: Vec<(u32, Vec<Option<LevelMask>>)>,
}

/// Bytes of a block's pixel mask on the wire.
fn mask_bytes(px: usize) -> usize {
    px.div_ceil(8)
}

impl BlockGrid {
    /// Pixels of block `b`.
    pub fn pixels(&self, b: usize) -> usize {
        let (x0, x1, y0, y1) = self.rect(b);
        ((x1 - x0) * (y1 - y0)) as usize
    }

    /// 64-bit words of a block's mask (for the largest block).
    pub fn words(&self) -> usize {
        ((self.block.0 * self.block.1) as usize).div_ceil(64).max(1)
    }
}

impl LevelDelta {
    /// Wire form: `nbx`, `nby` (u16 LE), `L` (u8), count (u32 LE), then per
    /// block its index (u32 LE), a u16 LE mask of the levels present, and per
    /// present level the pixel bits (`ceil(pixels / 8)` bytes) and the depth
    /// (f32 LE). The block's pixel count comes from the grid.
    pub fn encode(&self, grid: &BlockGrid) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(&self.nbx.to_le_bytes());
        out.extend_from_slice(&self.nby.to_le_bytes());
        out.push(self.levels);
        out.extend_from_slice(&(self.blocks.len() as u32).to_le_bytes());
        for (b, v) in &self.blocks {
            out.extend_from_slice(&b.to_le_bytes());
            let present = v
                .iter()
                .enumerate()
                .filter(|(_, m)| m.is_some())
                .fold(0u16, |m, (l, _)| m | 1 << l);
            out.extend_from_slice(&present.to_le_bytes());
            let nb = mask_bytes(grid.pixels(*b as usize));
            for m in v.iter().flatten() {
                for i in 0..nb {
                    out.push((m.bits.get(i / 8).copied().unwrap_or(0) >> (8 * (i % 8))) as u8);
                }
                out.extend_from_slice(&m.depth.to_le_bytes());
            }
        }
        out
    }

    /// Decodes [`LevelDelta::encode`]'s form against `grid`; never panics.
    /// Checks the shape, block indices (ascending, in range), padding bits,
    /// finite depths.
    pub fn decode(bytes: &[u8], grid: &BlockGrid) -> Result<LevelDelta, TableError> {
        let bad = || TableError::Length(bytes.len());
        let get = |at: usize, n: usize| bytes.get(at..at + n).ok_or_else(bad);
        let h = get(0, 9)?;
        let nbx = u16::from_le_bytes([h[0], h[1]]);
        let nby = u16::from_le_bytes([h[2], h[3]]);
        let levels = h[4];
        let count = u32::from_le_bytes([h[5], h[6], h[7], h[8]]) as usize;
        let (gx, gy) = grid.dims();
        if levels == 0 || levels > 16 || (nbx as u32, nby as u32) != (gx, gy) || count > grid.len()
        {
            return Err(bad());
        }
        let words = grid.words();
        let mut at = 9;
        let mut blocks = Vec::with_capacity(count);
        let mut prev: Option<u32> = None;
        for _ in 0..count {
            let h = get(at, 6)?;
            let b = u32::from_le_bytes([h[0], h[1], h[2], h[3]]);
            let present = u16::from_le_bytes([h[4], h[5]]);
            at += 6;
            if b as usize >= grid.len()
                || prev.is_some_and(|p| p >= b)
                || (levels < 16 && present >> levels != 0)
            {
                return Err(bad());
            }
            prev = Some(b);
            let px = grid.pixels(b as usize);
            let nb = mask_bytes(px);
            let mut v = vec![None; levels as usize];
            for (l, slot) in v.iter_mut().enumerate() {
                if present >> l & 1 == 0 {
                    continue;
                }
                let m = get(at, nb + 4)?;
                at += nb + 4;
                let mut bits = vec![0u64; words];
                for (i, &byte) in m[..nb].iter().enumerate() {
                    bits[i / 8] |= (byte as u64) << (8 * (i % 8));
                }
                if !px.is_multiple_of(8) && m[nb - 1] >> (px % 8) != 0 {
                    return Err(bad());
                }
                let d = f32::from_le_bytes([m[nb], m[nb + 1], m[nb + 2], m[nb + 3]]);
                if !d.is_finite() {
                    return Err(TableError::NonFinite(b as usize));
                }
                *slot = Some(LevelMask { bits, depth: d });
            }
            blocks.push((b, v));
        }
        if at != bytes.len() {
            return Err(bad());
        }
        Ok(LevelDelta {
            nbx,
            nby,
            levels,
            blocks,
        })
    }
}

/// Whether bit `p` of `bits` is set.
#[inline]
fn bit(bits: &[u64], p: usize) -> bool {
    bits[p / 64] >> (p % 64) & 1 == 1
}

/// The smallest depth at which every pixel of a block is certified
/// terminated from the nodes' masks (`per_node[k][l]`, `None`: level not
/// reached anywhere): per pixel the `L`-th smallest depth among the
/// (node, level) masks holding it, then the max over the block's `px`
/// pixels (`+inf` if a pixel has fewer than `L`). Also returns the work
/// (values inspected).
pub fn combine_masks(per_node: &[&[Option<LevelMask>]], px: usize, levels: usize) -> (f32, u64) {
    let mut worst = f32::NEG_INFINITY;
    let mut work = 0u64;
    let mut v: Vec<f32> = Vec::with_capacity(per_node.len() * levels);
    for p in 0..px {
        v.clear();
        for node in per_node {
            for m in node.iter().flatten() {
                work += 1;
                if bit(&m.bits, p) {
                    v.push(m.depth);
                }
            }
        }
        if v.len() < levels {
            return (f32::INFINITY, work);
        }
        let (_, nth, _) = v.select_nth_unstable_by(levels - 1, |a, b| a.total_cmp(b));
        worst = worst.max(*nth);
    }
    (worst, work)
}

/// The manager's store: every node's latest level masks per block, and the
/// combined per-entry `deepest`.
#[derive(Debug, Clone)]
pub struct LevelStore {
    grid: BlockGrid,
    levels: usize,
    nodes: usize,
    /// `[block]`: the nodes that sent something for it, with their masks.
    values: Vec<Vec<(usize, Vec<Option<LevelMask>>)>>,
    /// Combined per block.
    block: Vec<f32>,
}

impl LevelStore {
    /// An empty store for `nodes` nodes.
    pub fn new(grid: BlockGrid, levels: usize, nodes: usize) -> LevelStore {
        LevelStore {
            grid,
            levels,
            nodes,
            values: vec![Vec::new(); grid.len()],
            block: vec![f32::INFINITY; grid.len()],
        }
    }

    /// The block grid.
    pub fn grid(&self) -> &BlockGrid {
        &self.grid
    }

    /// Applies node `k`'s delta (its masks replace what it sent before for
    /// those blocks: each is a certificate that never expires, and a newer
    /// one holds more pixels), recombines the changed blocks (keeping per
    /// block the min with its previous combination) and writes the changed
    /// entries' `deepest` into `out` (per entry the min with its current
    /// value). Returns the work (values read), for the cost model.
    pub fn apply(
        &mut self,
        k: usize,
        d: &LevelDelta,
        out: &mut super::SharedTable,
    ) -> Result<u64, TableError> {
        let (nbx, nby) = self.grid.dims();
        if (d.nbx as u32, d.nby as u32) != (nbx, nby)
            || d.levels as usize != self.levels
            || k >= self.nodes
            || out.len() != (self.grid.n.0 * self.grid.n.1) as usize
        {
            return Err(TableError::Shape {
                got: (d.nbx, d.nby),
                want: (nbx as u16, nby as u16),
            });
        }
        let l = self.levels;
        let mut work = 0u64;
        let mut entries: Vec<usize> = Vec::new();
        for (b, v) in &d.blocks {
            let b = *b as usize;
            if v.len() != l {
                return Err(TableError::Length(v.len()));
            }
            let slot = &mut self.values[b];
            match slot.iter_mut().find(|(n, _)| *n == k) {
                Some(s) => s.1 = v.clone(),
                None => slot.push((k, v.clone())),
            }
            work += l as u64;
            let masks: Vec<&[Option<LevelMask>]> = slot.iter().map(|(_, m)| &m[..]).collect();
            let (c, w) = combine_masks(&masks, self.grid.pixels(b), l);
            work += w;
            if c < self.block[b] {
                self.block[b] = c;
                let e = self.grid.entry_of(b);
                if !entries.contains(&e) {
                    entries.push(e);
                }
            }
        }
        for e in entries {
            let mut m = f32::NEG_INFINITY;
            for b in self.grid.blocks_of(e) {
                m = m.max(self.block[b]);
                work += 1;
            }
            if m < out.deepest[e] {
                out.deepest[e] = m;
            }
        }
        Ok(work)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::SharedTable;

    #[test]
    fn grid_nests_blocks_in_entries() {
        let g = BlockGrid::new(300, 300, 20, 3);
        assert_eq!(
            (g.entry, g.block, g.per_entry, g.dims()),
            ((15, 15), (5, 5), (3, 3), (60, 60))
        );
        let mut count = vec![0u32; g.len()];
        for y in 0..300 {
            for x in 0..300 {
                let b = g.block_of(x, y);
                let (x0, x1, y0, y1) = g.rect(b);
                assert!(x0 <= x && x < x1 && y0 <= y && y < y1);
                assert_eq!(g.entry_of(b), ((y / 15) * 20 + x / 15) as usize);
                count[b] += 1;
            }
        }
        assert!(count.iter().all(|&c| c == 25));
        // A ragged grid: 17 px wide, D = 4 -> entries 5 px, sub 2 -> blocks 3 px.
        let g = BlockGrid::new(17, 9, 4, 2);
        let mut covered = 0;
        for e in 0..(g.n.0 * g.n.1) as usize {
            for b in g.blocks_of(e) {
                let (x0, x1, y0, y1) = g.rect(b);
                covered += (x1 - x0) * (y1 - y0);
                assert_eq!(g.entry_of(b), e);
            }
        }
        assert_eq!(covered, 17 * 9);
    }

    #[test]
    fn levels_and_combination() {
        let a = level_alphas(0.9, 4);
        assert_eq!(a.len(), 4);
        assert_eq!(a[3], 0.9);
        // Two nodes at transmittance 0.1^(1/2) each: terminated together.
        assert!((a[1] - (1.0 - 0.1f32.sqrt())).abs() < 1e-6);
        let inf = f32::INFINITY;
        let n1 = [1.0, 2.0, inf, inf];
        let n2 = [3.0, 4.0, inf, inf];
        assert_eq!(combine_block([&n1[..], &n2[..]].into_iter(), 4), 4.0);
        assert_eq!(combine_block([&n1[..]].into_iter(), 4), inf);
        let alone = [1.0, 1.0, 1.5, 2.0];
        assert_eq!(combine_block([&alone[..], &n2[..]].into_iter(), 4), 2.0);
    }

    fn mask(g: &BlockGrid, b: usize, px: &[usize], depth: f32) -> Option<LevelMask> {
        let mut bits = vec![0u64; g.words()];
        for &p in px {
            assert!(p < g.pixels(b));
            bits[p / 64] |= 1 << (p % 64);
        }
        Some(LevelMask { bits, depth })
    }

    #[test]
    fn delta_round_trip_and_hostile_bytes() {
        let g = BlockGrid::new(12, 6, 2, 2); // entries 6x3, blocks 3x2 (6 px)
        assert_eq!(
            (g.dims(), g.pixels(0), g.pixels(6), g.words()),
            ((4, 4), 6, 3, 1)
        );
        let d = LevelDelta {
            nbx: 4,
            nby: 4,
            levels: 3,
            blocks: vec![
                (
                    1,
                    vec![mask(&g, 1, &[0, 5], 1.0), mask(&g, 1, &[5], 2.0), None],
                ),
                (6, vec![None, None, None]),
            ],
        };
        let b = d.encode(&g);
        assert_eq!(b.len(), 9 + 6 + 2 * (1 + 4) + 6);
        assert_eq!(LevelDelta::decode(&b, &g).unwrap(), d);
        for cut in 0..b.len() {
            assert!(LevelDelta::decode(&b[..cut], &g).is_err());
        }
        let mut bad = b.clone();
        bad[9] = 9; // block index out of range
        assert!(LevelDelta::decode(&bad, &g).is_err());
        let mut pad = b.clone();
        pad[15] |= 0x80; // a bit past the block's 6 pixels
        assert!(LevelDelta::decode(&pad, &g).is_err());
        let mut nan = b.clone();
        nan[16..20].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(LevelDelta::decode(&nan, &g).is_err());
        assert!(LevelDelta::decode(&[b.clone(), vec![0]].concat(), &g).is_err());
        assert!(LevelDelta::decode(&b, &BlockGrid::new(12, 6, 2, 1)).is_err());
    }

    #[test]
    fn masks_combine_in_depth_and_across_space() {
        let g = BlockGrid::new(4, 2, 1, 1); // one entry, one 4x2 block
        let all: Vec<usize> = (0..8).collect();
        let (left, right): (Vec<usize>, Vec<usize>) = all.iter().partition(|&&p| p % 4 < 2);
        // Depth: two nodes at level 1 of 2 everywhere: terminated at the deeper.
        let a = [mask(&g, 0, &all, 1.0), None];
        let b = [mask(&g, 0, &all, 3.0), None];
        assert_eq!(combine_masks(&[&a, &b], 8, 2).0, 3.0);
        assert_eq!(combine_masks(&[&a], 8, 2).0, f32::INFINITY);
        // Space: each node terminates its half alone.
        let l = [mask(&g, 0, &left, 1.0), mask(&g, 0, &left, 2.0)];
        let r = [mask(&g, 0, &right, 4.0), mask(&g, 0, &right, 5.0)];
        assert_eq!(combine_masks(&[&l, &r], 8, 2).0, 5.0);
        assert_eq!(combine_masks(&[&l], 8, 2).0, f32::INFINITY);
    }

    #[test]
    fn store_combines_nodes() {
        let g = BlockGrid::new(4, 4, 2, 2); // entries 2x2 px, blocks 1x1
        let mut s = LevelStore::new(g, 2, 2);
        let mut t = SharedTable::empty(2, 2);
        let delta = |v: Vec<Option<LevelMask>>| LevelDelta {
            nbx: 4,
            nby: 4,
            levels: 2,
            blocks: [0u32, 1, 4, 5].iter().map(|&b| (b, v.clone())).collect(),
        };
        // Entry 0 = blocks 0, 1, 4, 5. Node 0 reaches level 1 everywhere at 1.0.
        s.apply(0, &delta(vec![mask(&g, 0, &[0], 1.0), None]), &mut t)
            .unwrap();
        assert!(!t.terminated(0));
        s.apply(1, &delta(vec![mask(&g, 0, &[0], 3.0), None]), &mut t)
            .unwrap();
        assert_eq!(t.deepest[0], 3.0);
        assert!(!t.terminated(1));
        // Node 1 later sees more in front (levels 1 and 2 by 1.5 and 2.0):
        // with node 0's level 1 at 1.0, the second smallest is 1.5.
        let both = vec![mask(&g, 0, &[0], 1.5), mask(&g, 0, &[0], 2.0)];
        s.apply(1, &delta(both), &mut t).unwrap();
        assert_eq!(t.deepest[0], 1.5);
        // A later, weaker certificate never loosens the table.
        s.apply(1, &delta(vec![mask(&g, 0, &[0], 9.0), None]), &mut t)
            .unwrap();
        assert_eq!(t.deepest[0], 1.5);
    }
}
