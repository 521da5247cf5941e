//! Release ordering: each node processes first the cells whose pixels other
//! nodes will cover soonest, so that their opacity has arrived when it gets
//! to them (`pvrsim cluster --release-lag`, pyramid structure with sharing).
//!
//! ## Why
//!
//! With the view-independent RCB placement, on view B six of the eight
//! nodes hold pieces whose every pixel has another node's cells in front
//! (`cargo run --release --example ert_gap -- ../shared/data/aorta-view-b.toml`):
//! the sequential pyramid skips 70 % of their cells, but only once the
//! nodes in front have scanned theirs. Scanning nearest-first, a back node
//! reaches its cells long before that.
//!
//! ## The schedule
//!
//! Node `k` scans its queue in nearest-first order; call `r_k(c) ∈ [0, 1)`
//! the position of cell `c` in it, a proxy for the fraction of the frame
//! after which `c` is scanned. Per screen block `b` (`B x B` pixels) node
//! `j` publishes `F_j(b)`, the nearest depth of its cells covering `b`, and
//! `R_j(b)`, the smallest `r_j` among them: from about time `R_j(b)` node
//! `j` lays opacity over `b` in front of everything behind `F_j(b)`. A cell
//! `c` of node `k` with nearest depth `z` and pixel blocks `B(c)` can be
//! skipped once every block is covered in front of `z`, so it is
//! *released* at
//!
//! ```text
//! T_k(c) = max_{b ∈ B(c)} min { R_j(b) : j ≠ k, F_j(b) < z }    (0 if some block has no such j)
//! ```
//!
//! and node `k` scans its cells by `max(r_k(c), T_k(c) + lag)` (1024
//! buckets, nearest-first inside a bucket): a cell nobody covers keeps its
//! place, a covered one waits until its coverers have had `lag` of the
//! frame to make it opaque. Cells arriving later (help, DLB) are keyed by
//! `T + lag`. This is scheduling only: which cells are skipped is decided
//! by the usual test, so the image is within the ERT bound whatever the
//! order.
//!
//! ## What travels
//!
//! At the start of the frame every node sends its blocks `(b, F_j(b),
//! R_j(b))` ([`ReleaseShare`], about 6 bytes per covered block). The manager
//! waits for all `N`, and answers node `k` with, per block it covers, the
//! lower envelope of `{(F_j(b), R_j(b)) : j ≠ k}` ([`ReleaseReply`]): the
//! pairs sorted by `F` ascending whose `R` is smaller than every earlier
//! one, which is all `T_k` needs. Costs charged: building the map
//! (`table_pixels_read` per block of each cell's range), every entry coded
//! or merged (`shared_entries_merged`, node and manager), the keys and the
//! bucket reorder (`cells_reordered`, priced as an ERT test per cell).

use super::pixel_share::{put_varint, Reader};
use super::table::TableError;

const TAG_SHARE: u8 = b'R';
const TAG_REPLY: u8 = b'Q';

/// Buckets of the scan key.
pub const BUCKETS: u32 = 1024;

/// Screen blocks of `block x block` pixels over a `width x height` image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlockMap {
    /// Block edge in pixels.
    pub block: u32,
    /// Blocks per row.
    pub bw: u32,
    /// Blocks per column.
    pub bh: u32,
}

impl BlockMap {
    /// Blocks of `block` pixels (at least 1) over `width x height`.
    pub fn new(width: u32, height: u32, block: u32) -> BlockMap {
        let block = block.max(1);
        BlockMap {
            block,
            bw: width.div_ceil(block).max(1),
            bh: height.div_ceil(block).max(1),
        }
    }

    /// Number of blocks.
    pub fn len(&self) -> usize {
        (self.bw * self.bh) as usize
    }

    /// Whether there is no block (never: at least 1 x 1).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Inclusive block range `[bx0, bx1, by0, by1]` of an inclusive pixel range.
    pub fn blocks(&self, range: [u32; 4]) -> [u32; 4] {
        let b = self.block;
        [
            (range[0] / b).min(self.bw - 1),
            (range[1] / b).min(self.bw - 1),
            (range[2] / b).min(self.bh - 1),
            (range[3] / b).min(self.bh - 1),
        ]
    }
}

/// Node → manager: per block the node covers, `(block, F, R)` (depth code
/// of its nearest cell there, smallest rank code there), ascending blocks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReleaseShare {
    /// Blocks per row and column.
    pub dims: (u32, u32),
    /// `(block, F code, R code)`.
    pub blocks: Vec<(u32, u16, u16)>,
}

fn header(out: &mut Vec<u8>, tag: u8, dims: (u32, u32), count: usize) {
    out.push(tag);
    out.extend_from_slice(&dims.0.to_le_bytes());
    out.extend_from_slice(&dims.1.to_le_bytes());
    out.extend_from_slice(&(count as u32).to_le_bytes());
}

fn read_header(r: &mut Reader, tag: u8, dims: (u32, u32), per: usize) -> Result<usize, TableError> {
    if r.u8()? != tag {
        return Err(r.err());
    }
    let d = (r.u32()?, r.u32()?);
    let count = r.u32()? as usize;
    if d != dims || count > r.b.len() / per {
        return Err(r.err());
    }
    Ok(count)
}

/// Reads a block index, delta-coded after `prev`, below `n`.
fn read_block(r: &mut Reader, prev: &mut Option<u32>, n: u32) -> Result<u32, TableError> {
    let d = r.varint()?;
    let b = match *prev {
        None => d,
        Some(q) if d > 0 => q.checked_add(d).ok_or_else(|| r.err())?,
        Some(_) => return Err(r.err()),
    };
    if b >= n {
        return Err(r.err());
    }
    *prev = Some(b);
    Ok(b)
}

impl ReleaseShare {
    /// Wire form: tag `R`, blocks per row and column (u32 LE), count (u32
    /// LE), then per block its index (varint delta, the first absolute),
    /// `F` and `R` (u16 LE).
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(13 + 6 * self.blocks.len());
        header(&mut out, TAG_SHARE, self.dims, self.blocks.len());
        let mut prev = None;
        for &(b, f, r) in &self.blocks {
            put_varint(&mut out, prev.map_or(b, |q: u32| b - q));
            prev = Some(b);
            out.extend_from_slice(&f.to_le_bytes());
            out.extend_from_slice(&r.to_le_bytes());
        }
        out
    }

    /// Decodes [`ReleaseShare::encode`]'s form for `dims` blocks; never panics.
    pub fn decode(bytes: &[u8], dims: (u32, u32)) -> Result<ReleaseShare, TableError> {
        let mut r = Reader { b: bytes, at: 0 };
        let count = read_header(&mut r, TAG_SHARE, dims, 5)?;
        let n = dims.0.checked_mul(dims.1).ok_or_else(|| r.err())?;
        let mut prev = None;
        let mut blocks = Vec::with_capacity(count);
        for _ in 0..count {
            let b = read_block(&mut r, &mut prev, n)?;
            blocks.push((b, r.u16()?, r.u16()?));
        }
        if r.at != bytes.len() {
            return Err(r.err());
        }
        Ok(ReleaseShare { dims, blocks })
    }
}

/// Manager → node: per block the node covers, the lower envelope of the
/// other nodes' `(F, R)`: `F` ascending, `R` strictly descending.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReleaseReply {
    /// Blocks per row and column.
    pub dims: (u32, u32),
    /// `(block, envelope)`, ascending blocks, envelopes non-empty.
    pub blocks: Vec<(u32, Vec<(u16, u16)>)>,
}

impl ReleaseReply {
    /// Wire form: tag `Q`, dims and count as [`ReleaseShare`], then per block
    /// its index (varint delta), the envelope's length (u8, 1..=255) and its
    /// pairs (`F`, `R`: u16 LE each).
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(13 + 6 * self.blocks.len());
        header(&mut out, TAG_REPLY, self.dims, self.blocks.len());
        let mut prev = None;
        for (b, env) in &self.blocks {
            put_varint(&mut out, prev.map_or(*b, |q: u32| b - q));
            prev = Some(*b);
            out.push(env.len() as u8);
            for &(f, r) in env {
                out.extend_from_slice(&f.to_le_bytes());
                out.extend_from_slice(&r.to_le_bytes());
            }
        }
        out
    }

    /// Decodes [`ReleaseReply::encode`]'s form for `dims` blocks; checks
    /// that every envelope is non-empty, `F` ascending and `R` strictly
    /// descending. Never panics.
    pub fn decode(bytes: &[u8], dims: (u32, u32)) -> Result<ReleaseReply, TableError> {
        let mut r = Reader { b: bytes, at: 0 };
        let count = read_header(&mut r, TAG_REPLY, dims, 6)?;
        let n = dims.0.checked_mul(dims.1).ok_or_else(|| r.err())?;
        let mut prev = None;
        let mut blocks = Vec::with_capacity(count);
        for _ in 0..count {
            let b = read_block(&mut r, &mut prev, n)?;
            let m = r.u8()? as usize;
            if m == 0 {
                return Err(r.err());
            }
            let mut env: Vec<(u16, u16)> = Vec::with_capacity(m);
            for _ in 0..m {
                let p = (r.u16()?, r.u16()?);
                if env.last().is_some_and(|&(f, q)| p.0 < f || p.1 >= q) {
                    return Err(r.err());
                }
                env.push(p);
            }
            blocks.push((b, env));
        }
        if r.at != bytes.len() {
            return Err(r.err());
        }
        Ok(ReleaseReply { dims, blocks })
    }

    /// The dense map a node looks cells up in.
    pub fn into_map(self) -> ReleaseMap {
        let n = (self.dims.0 * self.dims.1) as usize;
        let mut start = vec![0u32; n + 1];
        for (b, env) in &self.blocks {
            start[*b as usize + 1] = env.len() as u32;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let pairs = self.blocks.into_iter().flat_map(|(_, e)| e).collect();
        ReleaseMap {
            bw: self.dims.0,
            start,
            pairs,
        }
    }
}

/// The lower envelope of `(F, R)` pairs: sorted by `F` ascending (then `R`),
/// keeping each pair whose `R` is below every earlier one; at most 255.
pub fn envelope(mut pairs: Vec<(u16, u16)>) -> Vec<(u16, u16)> {
    pairs.sort_unstable();
    let mut out: Vec<(u16, u16)> = Vec::new();
    for p in pairs {
        if out.last().is_none_or(|&(f, r)| p.1 < r && p.0 >= f) {
            if out.last().is_some_and(|&(f, _)| f == p.0) {
                out.pop();
            }
            out.push(p);
        }
        if out.len() == 255 {
            break;
        }
    }
    out
}

/// A node's release map ([`ReleaseReply::into_map`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ReleaseMap {
    bw: u32,
    start: Vec<u32>,
    pairs: Vec<(u16, u16)>,
}

impl ReleaseMap {
    /// `T(c)` as a rank code for a cell over inclusive block range `br` with
    /// nearest depth code `z`, and the blocks looked at: 0 if some block has
    /// no other node in front of `z`.
    pub fn release(&self, br: [u32; 4], z: u16) -> (u16, u64) {
        let mut t = 0u16;
        let mut seen = 0u64;
        for by in br[2]..=br[3] {
            for bx in br[0]..=br[1] {
                seen += 1;
                let b = (by * self.bw + bx) as usize;
                let env = &self.pairs[self.start[b] as usize..self.start[b + 1] as usize];
                // The last pair with F < z has the smallest R among them.
                match env.iter().take_while(|p| p.0 < z).last() {
                    Some(&(_, r)) => t = t.max(r),
                    None => return (0, seen),
                }
            }
        }
        (t, seen)
    }
}

/// The manager's side: every node's share, then each node's reply.
#[derive(Debug, Clone)]
pub struct ReleaseStore {
    dims: (u32, u32),
    shares: Vec<Option<Vec<(u32, u16, u16)>>>,
}

impl ReleaseStore {
    /// A store for `nodes` nodes and `dims` blocks.
    pub fn new(dims: (u32, u32), nodes: usize) -> ReleaseStore {
        ReleaseStore {
            dims,
            shares: vec![None; nodes],
        }
    }

    /// Blocks per row and column.
    pub fn dims(&self) -> (u32, u32) {
        self.dims
    }

    /// Whether node `k`'s share has arrived.
    pub fn has(&self, k: usize) -> bool {
        self.shares.get(k).is_some_and(|s| s.is_some())
    }

    /// Keeps node `k`'s share (a second one is an error); returns the
    /// entries read and whether every node's share is in.
    pub fn put(&mut self, k: usize, s: ReleaseShare) -> Result<(u64, bool), TableError> {
        let slot = self.shares.get_mut(k).ok_or(TableError::Length(0))?;
        if slot.is_some() {
            return Err(TableError::Length(s.blocks.len()));
        }
        let n = s.blocks.len() as u64;
        *slot = Some(s.blocks);
        Ok((n, self.shares.iter().all(|s| s.is_some())))
    }

    /// Every node's reply (call once all shares are in), and the entries
    /// read and written.
    pub fn replies(&self) -> (Vec<ReleaseReply>, u64) {
        let nb = (self.dims.0 * self.dims.1) as usize;
        let mut per: Vec<Vec<(u16, u16, u32)>> = vec![Vec::new(); nb];
        let mut work = 0u64;
        for (k, s) in self.shares.iter().enumerate() {
            for &(b, f, r) in s.iter().flatten() {
                per[b as usize].push((f, r, k as u32));
                work += 1;
            }
        }
        let replies = self
            .shares
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let blocks = s
                    .iter()
                    .flatten()
                    .filter_map(|&(b, _, _)| {
                        let others: Vec<(u16, u16)> = per[b as usize]
                            .iter()
                            .filter(|e| e.2 != k as u32)
                            .map(|e| (e.0, e.1))
                            .collect();
                        work += others.len() as u64 + 1;
                        let env = envelope(others);
                        (!env.is_empty()).then_some((b, env))
                    })
                    .collect();
                ReleaseReply {
                    dims: self.dims,
                    blocks,
                }
            })
            .collect();
        (replies, work)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn envelope_keeps_decreasing_ranks() {
        let e = envelope(vec![(5, 10), (1, 50), (3, 20), (4, 30), (1, 40), (9, 1)]);
        assert_eq!(e, vec![(1, 40), (3, 20), (5, 10), (9, 1)]);
    }

    #[test]
    fn release_is_the_max_over_blocks_of_the_min_in_front() {
        let reply = ReleaseReply {
            dims: (2, 1),
            blocks: vec![(0, vec![(10, 500), (20, 100)]), (1, vec![(15, 300)])],
        };
        let m = reply.into_map();
        // Block 0 at z = 25: min R of F < 25 = 100; block 1: 300.
        assert_eq!(m.release([0, 1, 0, 0], 25).0, 300);
        // z = 12: block 0 gives 500, block 1 has nobody in front: exposed.
        assert_eq!(m.release([0, 1, 0, 0], 12).0, 0);
        assert_eq!(m.release([0, 0, 0, 0], 12), (500, 1));
    }

    #[test]
    fn store_excludes_the_node_itself() {
        let mut s = ReleaseStore::new((1, 1), 3);
        let one = ReleaseShare {
            dims: (1, 1),
            blocks: vec![(0, 1, 9)],
        };
        assert!(!s.put(0, one).unwrap().1);
        s.put(
            1,
            ReleaseShare {
                dims: (1, 1),
                blocks: vec![(0, 5, 2)],
            },
        )
        .unwrap();
        assert!(s.put(1, ReleaseShare::default()).is_err());
        let (_, all) = s
            .put(
                2,
                ReleaseShare {
                    dims: (1, 1),
                    blocks: vec![],
                },
            )
            .unwrap();
        assert!(all);
        let (r, _) = s.replies();
        assert_eq!(r[0].blocks, vec![(0, vec![(5, 2)])]);
        assert_eq!(r[1].blocks, vec![(0, vec![(1, 9)])]);
        assert!(r[2].blocks.is_empty());
    }

    proptest! {
        #[test]
        fn wire_forms_round_trip_and_never_panic(
            raw in proptest::collection::btree_map(0u32..64, (any::<u16>(), any::<u16>()), 0..40),
            junk in proptest::collection::vec(any::<u8>(), 0..64),
        ) {
            let s = ReleaseShare { dims: (8, 8), blocks: raw.iter().map(|(&b, &(f, r))| (b, f, r)).collect() };
            prop_assert_eq!(ReleaseShare::decode(&s.encode(), (8, 8)).unwrap(), s.clone());
            let q = ReleaseReply {
                dims: (8, 8),
                blocks: raw.iter().map(|(&b, &(f, r))| (b, envelope(vec![(f, r), (f / 2, r.saturating_add(1))]))).collect(),
            };
            prop_assert_eq!(ReleaseReply::decode(&q.encode(), (8, 8)).unwrap(), q);
            prop_assert!(ReleaseShare::decode(&s.encode(), (8, 7)).is_err());
            let _ = ReleaseShare::decode(&junk, (8, 8));
            let _ = ReleaseReply::decode(&junk, (8, 8));
        }

        #[test]
        fn release_matches_brute_force(
            pairs in proptest::collection::vec((0u16..100, 0u16..1000), 1..8),
            z in 0u16..110,
        ) {
            let env = envelope(pairs.clone());
            let m = ReleaseReply { dims: (1, 1), blocks: vec![(0, env)] }.into_map();
            let want = pairs.iter().filter(|p| p.0 < z).map(|p| p.1).min().unwrap_or(0);
            prop_assert_eq!(m.release([0, 0, 0, 0], z).0, want);
        }
    }
}
