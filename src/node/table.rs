//! The ERT table of one node over the whole image, and the [`SharedTable`]
//! that travels between a node and the manager (paper §3.2).
//!
//! The image is cut into `D x D` entries of `ceil(W / D) x ceil(H / D)`
//! pixels (the last row and column narrower), the paper's global table: the
//! same entries on every node, so that entries can be exchanged.
//!
//! As in the single-machine table ([`crate::render::cell::ert::table`]) an
//! entry's `terminated` bit and `deepest` depth are held in one `f32`:
//! `deepest = +inf` means "not terminated". A node keeps two values per entry:
//!
//! - `local`: the max over the entry's pixels of the node's own per-pixel
//!   termination depths (from its own lists), recomputed where pixels changed;
//! - `shared`: the min of everything the manager ever sent for the entry.
//!
//! A cell is tested against `min(local, shared)`.
//!
//! ## Why `min(local, shared)` over terminated entries is safe
//!
//! A terminated entry with `deepest = d` on node `k` says: for every pixel of
//! the entry, the segments node `k` holds, composited front to back, reach the
//! threshold in front of `d`. Those segments all end up in the final image,
//! and the segments of other nodes (and of cells not scanned yet) only fill
//! the gaps between them: cells are disjoint, so segments of different nodes
//! never overlap in depth, and "over" never lowers alpha. So the final
//! opacity in front of `d` is at least the threshold for every pixel of the
//! entry, *whichever node asks*: a cell of any node whose nearest depth is
//! behind `d` and whose pixels lie in the entry is attenuated by at least
//! `1 - threshold` — exactly the single-machine guarantee and error bound.
//! Each terminated entry of each node is such a certificate, so the smallest
//! `d` among them is the strongest valid one; a non-terminated entry
//! (`+inf`) certifies nothing and drops out of the `min` by itself. The
//! certificate never expires (segments are only added, and work handed to
//! another node is unprocessed work, not segments), so a stale shared table
//! is still correct, only weaker; keeping the min of all received values is
//! therefore safe too.
//!
//! Combining per entry (not per pixel) is weaker than the union of the
//! nodes' lists would allow — a pixel terminated by node 1's segments plus
//! node 2's is terminated on neither — but it is what the paper exchanges:
//! one bit and one depth per entry.

use super::ops::OpCounts;
use crate::render::cell::ert::table::entry_deepest;

/// Entries of a `width x height` image cut into `d x d`: `(entry width, entry height)` in pixels.
pub fn entry_px(width: u32, height: u32, d: u32) -> (u32, u32) {
    let d = d.max(1);
    (width.div_ceil(d).max(1), height.div_ceil(d).max(1))
}

/// The ERT information that travels: per entry, `deepest` (`+inf`: not
/// terminated), row-major over `nx x ny` entries.
#[derive(Debug, Clone, PartialEq)]
pub struct SharedTable {
    /// Entries per row.
    pub nx: u16,
    /// Entries per column.
    pub ny: u16,
    /// Per entry, `deepest` or `+inf`.
    pub deepest: Vec<f32>,
}

/// Why a shared table was rejected.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum TableError {
    /// Bytes too short or too long for the header and bitmap.
    #[error("shared table: {0} bytes do not match the header")]
    Length(usize),
    /// A terminated entry with a NaN or infinite depth.
    #[error("shared table: entry {0} is terminated with a non-finite depth")]
    NonFinite(usize),
    /// A table of another shape.
    #[error("shared table: {got:?} entries, expected {want:?}")]
    Shape {
        /// Received (nx, ny).
        got: (u16, u16),
        /// Expected (nx, ny).
        want: (u16, u16),
    },
}

impl SharedTable {
    /// A table of `nx x ny` entries, nothing terminated.
    pub fn empty(nx: u16, ny: u16) -> SharedTable {
        SharedTable {
            nx,
            ny,
            deepest: vec![f32::INFINITY; nx as usize * ny as usize],
        }
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.deepest.len()
    }

    /// Whether it has no entries.
    pub fn is_empty(&self) -> bool {
        self.deepest.is_empty()
    }

    /// Whether entry `e` is terminated.
    pub fn terminated(&self, e: usize) -> bool {
        self.deepest[e].is_finite()
    }

    /// Number of terminated entries.
    pub fn terminated_count(&self) -> usize {
        self.deepest.iter().filter(|d| d.is_finite()).count()
    }

    /// The compact wire form: `nx`, `ny` (u16 LE), the `terminated` bits
    /// (row-major, LSB first, `ceil(n / 8)` bytes), then one f32 LE `deepest`
    /// per terminated entry, in entry order. The paper's "1 bit + one depth
    /// per entry", with the depths of non-terminated entries left out.
    pub fn encode(&self) -> Vec<u8> {
        let n = self.len();
        let mut out = Vec::with_capacity(self.encoded_size() as usize);
        out.extend_from_slice(&self.nx.to_le_bytes());
        out.extend_from_slice(&self.ny.to_le_bytes());
        let mut bits = vec![0u8; n.div_ceil(8)];
        for (e, d) in self.deepest.iter().enumerate() {
            if d.is_finite() {
                bits[e / 8] |= 1 << (e % 8);
            }
        }
        out.extend_from_slice(&bits);
        for d in self.deepest.iter().filter(|d| d.is_finite()) {
            out.extend_from_slice(&d.to_le_bytes());
        }
        out
    }

    /// Bytes of [`SharedTable::encode`]: `4 + ceil(n / 8) + 4 * terminated`.
    pub fn encoded_size(&self) -> u64 {
        (4 + self.len().div_ceil(8) + 4 * self.terminated_count()) as u64
    }

    /// Bytes of the fixed-size form (every entry's depth sent):
    /// `4 + ceil(n / 8) + 4 n`, the upper bound of [`SharedTable::encoded_size`].
    pub fn dense_size(&self) -> u64 {
        (4 + self.len().div_ceil(8) + 4 * self.len()) as u64
    }

    /// Decodes [`SharedTable::encode`]'s form; never panics.
    pub fn decode(bytes: &[u8]) -> Result<SharedTable, TableError> {
        let bad = || TableError::Length(bytes.len());
        if bytes.len() < 4 {
            return Err(bad());
        }
        let nx = u16::from_le_bytes([bytes[0], bytes[1]]);
        let ny = u16::from_le_bytes([bytes[2], bytes[3]]);
        let n = nx as usize * ny as usize;
        let nb = n.div_ceil(8);
        let bits = bytes.get(4..4 + nb).ok_or_else(bad)?;
        let set = |e: usize| bits[e / 8] >> (e % 8) & 1 == 1;
        let terminated = (0..n).filter(|&e| set(e)).count();
        if bytes.len() != 4 + nb + 4 * terminated
            || bits.iter().enumerate().any(|(i, &b)| {
                // Padding bits past the last entry must be zero.
                i == nb - 1 && !n.is_multiple_of(8) && b >> (n % 8) != 0
            })
        {
            return Err(bad());
        }
        let mut depths = bytes[4 + nb..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]));
        let mut deepest = vec![f32::INFINITY; n];
        for (e, d) in deepest.iter_mut().enumerate() {
            if set(e) {
                let v = depths.next().ok_or_else(bad)?;
                if !v.is_finite() {
                    return Err(TableError::NonFinite(e));
                }
                *d = v;
            }
        }
        Ok(SharedTable { nx, ny, deepest })
    }
}

/// A node's table over the whole image: local and shared `deepest` per entry.
#[derive(Debug, Clone)]
pub struct NodeTable {
    /// Image width and height.
    size: (u32, u32),
    /// Entry width and height in pixels.
    entry: (u32, u32),
    /// Entries per row and column.
    n: (u32, u32),
    local: Vec<f32>,
    shared: Vec<f32>,
    dirty_flag: Vec<bool>,
    dirty: Vec<u32>,
}

impl NodeTable {
    /// A `d x d` table over a `width x height` image (fewer entries along an
    /// axis shorter than `d` pixels). Nothing terminated.
    pub fn new(width: u32, height: u32, d: u32) -> NodeTable {
        let entry = entry_px(width, height, d);
        let n = (width.div_ceil(entry.0), height.div_ceil(entry.1));
        let len = (n.0 * n.1) as usize;
        NodeTable {
            size: (width, height),
            entry,
            n,
            local: vec![f32::INFINITY; len],
            shared: vec![f32::INFINITY; len],
            dirty_flag: vec![false; len],
            dirty: Vec::new(),
        }
    }

    /// Entries per row and column.
    pub fn dims(&self) -> (u32, u32) {
        self.n
    }

    /// Entry width and height in pixels.
    pub fn entry_px(&self) -> (u32, u32) {
        self.entry
    }

    /// The value a cell is tested against: `min(local, shared)`.
    #[inline]
    pub fn effective(&self, e: usize) -> f32 {
        self.local[e].min(self.shared[e])
    }

    /// Notes that the termination depth of pixel `(x, y)` changed.
    #[inline]
    pub fn mark(&mut self, x: u32, y: u32) {
        let e = ((y / self.entry.1) * self.n.0 + x / self.entry.0) as usize;
        if !self.dirty_flag[e] {
            self.dirty_flag[e] = true;
            self.dirty.push(e as u32);
        }
    }

    /// Recomputes the marked entries' `local` from per-pixel depths `depth`
    /// (row-major over the image); counts entries and pixels read.
    pub fn rebuild(&mut self, depth: &[f32], ops: &mut OpCounts) {
        let (w, h) = self.size;
        for &e in &self.dirty {
            let (ex, ey) = (e % self.n.0, e / self.n.0);
            let (x0, y0) = (ex * self.entry.0, ey * self.entry.1);
            let (x1, y1) = ((x0 + self.entry.0).min(w), (y0 + self.entry.1).min(h));
            self.local[e as usize] = entry_deepest(depth, w, x0, x1, y0, y1);
            self.dirty_flag[e as usize] = false;
            ops.table_entries_updated += 1;
            ops.table_pixels_read += ((x1 - x0) * (y1 - y0)) as u64;
        }
        self.dirty.clear();
    }

    /// The node's own information, to send to the manager.
    pub fn local_table(&self) -> SharedTable {
        SharedTable {
            nx: self.n.0 as u16,
            ny: self.n.1 as u16,
            deepest: self.local.clone(),
        }
    }

    /// The shared values received so far.
    pub fn shared_table(&self) -> SharedTable {
        SharedTable {
            nx: self.n.0 as u16,
            ny: self.n.1 as u16,
            deepest: self.shared.clone(),
        }
    }

    /// Keeps, per entry, the min of the shared values received so far and `t`'s.
    pub fn apply_shared(&mut self, t: &SharedTable) -> Result<u64, TableError> {
        let want = (self.n.0 as u16, self.n.1 as u16);
        if (t.nx, t.ny) != want || t.deepest.len() != self.shared.len() {
            return Err(TableError::Shape {
                got: (t.nx, t.ny),
                want,
            });
        }
        if let Some(e) = t.deepest.iter().position(|d| d.is_nan()) {
            return Err(TableError::NonFinite(e));
        }
        for (s, &d) in self.shared.iter_mut().zip(&t.deepest) {
            *s = s.min(d);
        }
        Ok(t.deepest.len() as u64)
    }

    /// The paper's test: the cell's pixel range (inclusive, image pixels)
    /// lies in one entry, terminated in front of `near`.
    #[inline]
    pub fn skip_single(&self, range: [u32; 4], near: f32) -> bool {
        let [x0, x1, y0, y1] = range;
        let (e0, e1) = (x0 / self.entry.0, x1 / self.entry.0);
        let (f0, f1) = (y0 / self.entry.1, y1 / self.entry.1);
        e0 == e1 && f0 == f1 && self.effective((f0 * self.n.0 + e0) as usize) < near
    }

    /// Every entry the range covers is terminated in front of `near`.
    #[inline]
    pub fn skip_multi(&self, range: [u32; 4], near: f32) -> bool {
        let [x0, x1, y0, y1] = range;
        for f in y0 / self.entry.1..=y1 / self.entry.1 {
            for e in x0 / self.entry.0..=x1 / self.entry.0 {
                // NaN-safe: a NaN depth or near never skips.
                if self
                    .effective((f * self.n.0 + e) as usize)
                    .partial_cmp(&near)
                    != Some(std::cmp::Ordering::Less)
                {
                    return false;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encode_round_trip_and_size() {
        let mut t = SharedTable::empty(3, 3);
        t.deepest[0] = 1.5;
        t.deepest[8] = -2.0;
        let b = t.encode();
        assert_eq!(b.len() as u64, t.encoded_size());
        assert_eq!(b.len(), 4 + 2 + 8);
        assert_eq!(SharedTable::decode(&b).unwrap(), t);
        assert_eq!(t.dense_size(), 4 + 2 + 36);
        // Hostile: truncated, padded, non-finite, stray padding bits.
        assert!(SharedTable::decode(&b[..b.len() - 1]).is_err());
        assert!(SharedTable::decode(&[b.clone(), vec![0]].concat()).is_err());
        assert!(SharedTable::decode(&[1]).is_err());
        let mut nan = b.clone();
        nan[6..10].copy_from_slice(&f32::NAN.to_le_bytes());
        assert_eq!(SharedTable::decode(&nan), Err(TableError::NonFinite(0)));
        let mut pad = b.clone();
        pad[5] |= 0x80;
        assert!(SharedTable::decode(&pad).is_err());
    }

    #[test]
    fn node_table_uses_min_of_local_and_shared() {
        let mut t = NodeTable::new(4, 4, 2);
        assert_eq!(t.entry_px(), (2, 2));
        let mut depth = vec![f32::INFINITY; 16];
        for y in 0..2 {
            for x in 0..2 {
                depth[y * 4 + x] = 5.0 + x as f32;
                t.mark(x as u32, y as u32);
            }
        }
        let mut ops = OpCounts::default();
        t.rebuild(&depth, &mut ops);
        assert_eq!((ops.table_entries_updated, ops.table_pixels_read), (1, 4));
        assert!(t.skip_single([0, 1, 0, 1], 6.5) && !t.skip_single([0, 1, 0, 1], 6.0));
        let mut s = SharedTable::empty(2, 2);
        s.deepest[0] = 3.0;
        s.deepest[3] = 1.0;
        t.apply_shared(&s).unwrap();
        assert!(t.skip_single([0, 1, 0, 1], 3.5));
        assert!(t.skip_single([2, 3, 2, 3], 1.5));
        assert!(
            !t.skip_multi([1, 2, 1, 2], 10.0),
            "entries 1 and 2 not terminated"
        );
        // Received values never loosen.
        t.apply_shared(&SharedTable::empty(2, 2)).unwrap();
        assert!(t.skip_single([2, 3, 2, 3], 1.5));
        assert!(t.apply_shared(&SharedTable::empty(3, 2)).is_err());
        assert_eq!(t.local_table().deepest[0], 6.0);
    }
}
