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
//! Here a node shares, instead, for each **block** (an entry cut into
//! `sub x sub` blocks) and each of `L` **opacity levels**
//! `a_l = 1 - (1 - thr)^(l / L)` (`a_L = thr`), the depth by which every
//! pixel of the block has reached `a_l` in the node's own lists (`+inf`:
//! some pixel has not). Transmittances multiply over disjoint segments, and
//! the segments of different nodes are disjoint (cells are), so at depth `z`
//! a pixel's transmittance over the union of all nodes' segments is at most
//! `prod_k (1 - thr)^(l_k / L)` where `l_k` is the number of node `k`'s
//! levels reached by `z`; it is at most `1 - thr` (terminated) as soon as
//! `sum_k l_k >= L`. Counting one unit per (node, level) value `<= z`, the
//! smallest such `z` for a block is simply the **`L`-th smallest value** over
//! all nodes' values for that block ([`combine_block`]). An entry's
//! `deepest` is the max over its blocks: a valid certificate with the same
//! error bound as the paper's table, up to the `f32` rounding of the levels
//! (the per-pixel test `acc >= a_l` is `f32`, as the sequential one is).
//! With `L = 1` and `sub = 1` this is exactly the paper's rule.
//!
//! Nodes send only the blocks whose values changed since their last share
//! ([`LevelDelta`]); the manager keeps every node's latest values, recombines
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

/// The blocks whose level values changed since a node's last share.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LevelDelta {
    /// Blocks per row and column.
    pub nbx: u16,
    /// Blocks per column.
    pub nby: u16,
    /// Levels `L` (1..=16).
    pub levels: u8,
    /// Changed blocks, ascending, with their `L` values (`+inf`: not reached).
    pub blocks: Vec<(u32, Vec<f32>)>,
}

impl LevelDelta {
    /// Wire form: `nbx`, `ny` (u16 LE), `L` (u8), count (u32 LE), then per
    /// block its index (u32 LE), a u16 LE mask of the finite levels and one
    /// f32 LE per finite level.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.encoded_size() as usize);
        out.extend_from_slice(&self.nbx.to_le_bytes());
        out.extend_from_slice(&self.nby.to_le_bytes());
        out.push(self.levels);
        out.extend_from_slice(&(self.blocks.len() as u32).to_le_bytes());
        for (b, v) in &self.blocks {
            out.extend_from_slice(&b.to_le_bytes());
            let mask = v
                .iter()
                .enumerate()
                .filter(|(_, d)| d.is_finite())
                .fold(0u16, |m, (l, _)| m | 1 << l);
            out.extend_from_slice(&mask.to_le_bytes());
            for d in v.iter().filter(|d| d.is_finite()) {
                out.extend_from_slice(&d.to_le_bytes());
            }
        }
        out
    }

    /// Bytes of [`LevelDelta::encode`].
    pub fn encoded_size(&self) -> u64 {
        9 + self
            .blocks
            .iter()
            .map(|(_, v)| 6 + 4 * v.iter().filter(|d| d.is_finite()).count() as u64)
            .sum::<u64>()
    }

    /// Decodes [`LevelDelta::encode`]'s form; never panics. Checks the
    /// shape, block indices (ascending, in range), finite depths.
    pub fn decode(bytes: &[u8]) -> Result<LevelDelta, TableError> {
        let bad = || TableError::Length(bytes.len());
        let get = |at: usize, n: usize| bytes.get(at..at + n).ok_or_else(bad);
        let h = get(0, 9)?;
        let nbx = u16::from_le_bytes([h[0], h[1]]);
        let nby = u16::from_le_bytes([h[2], h[3]]);
        let levels = h[4];
        let count = u32::from_le_bytes([h[5], h[6], h[7], h[8]]) as usize;
        if levels == 0 || levels > 16 || count > nbx as usize * nby as usize {
            return Err(bad());
        }
        let mut at = 9;
        let mut blocks = Vec::with_capacity(count);
        let mut prev: Option<u32> = None;
        for _ in 0..count {
            let h = get(at, 6)?;
            let b = u32::from_le_bytes([h[0], h[1], h[2], h[3]]);
            let mask = u16::from_le_bytes([h[4], h[5]]);
            at += 6;
            if b as usize >= nbx as usize * nby as usize
                || prev.is_some_and(|p| p >= b)
                || (levels < 16 && mask >> levels != 0)
            {
                return Err(bad());
            }
            prev = Some(b);
            let mut v = vec![f32::INFINITY; levels as usize];
            for (l, d) in v.iter_mut().enumerate() {
                if mask >> l & 1 == 1 {
                    let c = get(at, 4)?;
                    at += 4;
                    let x = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
                    if !x.is_finite() {
                        return Err(TableError::NonFinite(b as usize));
                    }
                    *d = x;
                }
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

/// The manager's store: every node's latest level values per block, and
/// the combined per-entry `deepest`.
#[derive(Debug, Clone)]
pub struct LevelStore {
    grid: BlockGrid,
    levels: usize,
    nodes: usize,
    /// `[node][block * L + l]`.
    values: Vec<Vec<f32>>,
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
            values: vec![vec![f32::INFINITY; grid.len() * levels]; nodes],
            block: vec![f32::INFINITY; grid.len()],
        }
    }

    /// Applies node `k`'s delta (per value the min with what it sent before),
    /// recombines the changed blocks and writes the changed entries' `deepest`
    /// into `out` (per entry the min with its current value). Returns the
    /// number of values read (the manager's work, for the cost model).
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
            let mine = &mut self.values[k][b * l..(b + 1) * l];
            for (m, &x) in mine.iter_mut().zip(v) {
                *m = m.min(x);
            }
            work += l as u64;
            let c = combine_block(self.values.iter().map(|vals| &vals[b * l..(b + 1) * l]), l);
            work += (self.nodes * l) as u64;
            if c < self.block[b] {
                self.block[b] = c;
                let e = self.grid.entry_of(b);
                if entries.last() != Some(&e) && !entries.contains(&e) {
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

    #[test]
    fn delta_round_trip_and_hostile_bytes() {
        let inf = f32::INFINITY;
        let d = LevelDelta {
            nbx: 4,
            nby: 2,
            levels: 3,
            blocks: vec![(1, vec![1.0, 2.0, inf]), (6, vec![inf, inf, inf])],
        };
        let b = d.encode();
        assert_eq!(b.len() as u64, d.encoded_size());
        assert_eq!(LevelDelta::decode(&b).unwrap(), d);
        for cut in 0..b.len() {
            assert!(LevelDelta::decode(&b[..cut]).is_err());
        }
        let mut bad = b.clone();
        bad[9] = 9; // block index out of range
        assert!(LevelDelta::decode(&bad).is_err());
        let mut nan = b.clone();
        nan[15..19].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(LevelDelta::decode(&nan).is_err());
        assert!(LevelDelta::decode(&[b.clone(), vec![0]].concat()).is_err());
    }

    #[test]
    fn store_combines_nodes() {
        let g = BlockGrid::new(4, 4, 2, 2); // entries 2x2 px, blocks 1x1
        let mut s = LevelStore::new(g, 2, 2);
        let mut t = SharedTable::empty(2, 2);
        let inf = f32::INFINITY;
        // Entry 0 = blocks 0, 1, 4, 5. Node 0 reaches level 1 everywhere at 1.0.
        let all = |v: Vec<f32>| LevelDelta {
            nbx: 4,
            nby: 4,
            levels: 2,
            blocks: [0u32, 1, 4, 5].iter().map(|&b| (b, v.clone())).collect(),
        };
        s.apply(0, &all(vec![1.0, inf]), &mut t).unwrap();
        assert!(!t.terminated(0));
        s.apply(1, &all(vec![3.0, inf]), &mut t).unwrap();
        assert_eq!(t.deepest[0], 3.0);
        assert!(!t.terminated(1));
        // Node 1 later sees more in front: only improves.
        s.apply(1, &all(vec![2.0, 5.0]), &mut t).unwrap();
        assert_eq!(t.deepest[0], 2.0);
    }
}
