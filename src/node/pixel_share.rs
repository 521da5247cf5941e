//! Per-pixel opacity-level sharing: the cluster's ERT at the strength of the
//! sequential pyramid.
//!
//! ## Why
//!
//! The paper's manager keeps one `(terminated, deepest)` entry per `D x D`
//! subscreen and takes, per entry, the minimum `deepest` of the nodes whose
//! own entry is terminated. Two things cap it on data split over nodes:
//! an entry is terminated only when *every* pixel of it is, and only when
//! *one* node's segments alone reach the threshold. [`super::levels`]
//! removed the second cap per block; this module removes both: entries are
//! single pixels, and opacity composes across nodes.
//!
//! ## What a node sends
//!
//! For each of `L` levels `a_l = 1 - (1 - thr)^(l / L)` ([`level_alphas`])
//! and each pixel, the depth `d_{k,l}(p)` at which node `k`'s *own* segments
//! (front to back, gaps allowed) first reach `a_l`: the `z_back` of the
//! segment where the running alpha crosses it (`+inf` if not yet). It is a
//! certificate: node `k`'s segments in front of `d_{k,l}` have transmittance
//! at most `(1 - thr)^(l / L)`, and segments are only ever added, so it never
//! expires; the node keeps per value the minimum over its updates and sends
//! only the pixels whose values changed since its last share
//! ([`PixelLevels`]).
//!
//! ## What the manager combines
//!
//! Different nodes' segments are disjoint (cells are), and transmittances of
//! disjoint stretches multiply, so at depth `z` a pixel's true transmittance
//! is at most `prod_k (1 - thr)^(c_k(z) / L)`, `c_k(z)` the number of levels
//! of node `k` certified at depths `<= z`. It is `<= 1 - thr` once
//! `sum_k c_k(z) >= L`: the pixel's certified termination depth is the
//! **`L`-th smallest** of all nodes' values `d_{k,l}(p)` ([`PixelStore`]).
//! That is the manager's entry in the paper's format — `terminated` (finite)
//! and `deepest` — at the granularity of one pixel. Since a node's new
//! values are never larger than its old ones, replacing them can only lower
//! the combination; the manager keeps the minimum anyway, so a faulty node
//! cannot raise an entry.
//!
//! ## What comes back
//!
//! The certified depths that changed since that node's last reply
//! ([`PixelDepths`], from a change log: `O(changes)` per reply, not
//! `O(pixels)`). The node lowers its per-pixel depths and its max-pyramid
//! tests cells against `min(own, shared)`: the sequential renderer's test.
//!
//! ## Bytes
//!
//! Depths travel as `u16` codes over the frame's depth range
//! ([`DepthQuant`]), always **rounded up** (a deeper certificate is still a
//! certificate), `u16::MAX` meaning "not reached". Pixel indices are
//! delta-coded LEB128 varints over ascending indices. A pixel-level share
//! costs about `1 + 2 L` bytes per changed pixel, a reply about 3 bytes per
//! changed entry.
//!
//! ## Error bound
//!
//! The same as the sequential renderer's: a cell is skipped only behind a
//! depth where the pixel's true accumulated opacity is provably at least the
//! threshold (up to `f32` rounding of the levels, as in [`super::levels`]).

use super::levels::level_alphas;
use super::shard_map::ShardMap;
use super::table::TableError;

/// The code of "not reached / not terminated".
pub const NOT_REACHED: u16 = u16::MAX;

/// `u16` codes for depths over `[z0, z1]`, rounded up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthQuant {
    z0: f32,
    step: f32,
}

impl DepthQuant {
    /// Codes over the depth range `[z0, z1]` of a frame (any depth a segment
    /// can have lies at or below `z1`; depths below `z0` get code 0).
    pub fn new(z0: f32, z1: f32) -> DepthQuant {
        let span = if z1.is_finite() && z0.is_finite() && z1 > z0 {
            z1 - z0
        } else {
            1.0
        };
        DepthQuant {
            z0: if z0.is_finite() { z0 } else { 0.0 },
            // One step of headroom so that z1 itself is representable after
            // rounding up.
            step: span / (NOT_REACHED - 2) as f32,
        }
    }

    /// Width of the coded depth range.
    pub fn span(&self) -> f32 {
        self.step * (NOT_REACHED - 2) as f32
    }

    /// The smallest code whose value is `>= z` (`NOT_REACHED` for `+inf`, NaN,
    /// or depths beyond the range).
    pub fn up(&self, z: f32) -> u16 {
        if z.is_nan() || z == f32::INFINITY {
            return NOT_REACHED;
        }
        let q = ((z - self.z0) / self.step).ceil();
        if q <= 0.0 {
            return 0;
        }
        if q >= (NOT_REACHED - 1) as f32 {
            return if self.value(NOT_REACHED - 1) >= z {
                NOT_REACHED - 1
            } else {
                NOT_REACHED
            };
        }
        let mut q = q as u16;
        // Float rounding in the division: step up until the value covers z,
        // and down while the code below still does.
        while q < NOT_REACHED - 1 && self.value(q) < z {
            q += 1;
        }
        while q > 0 && self.value(q - 1) >= z {
            q -= 1;
        }
        if self.value(q) < z {
            NOT_REACHED
        } else {
            q
        }
    }

    /// The depth of code `q` (`+inf` for `NOT_REACHED`).
    #[inline]
    pub fn value(&self, q: u16) -> f32 {
        if q == NOT_REACHED {
            f32::INFINITY
        } else {
            self.z0 + q as f32 * self.step
        }
    }
}

pub(crate) fn put_varint(out: &mut Vec<u8>, mut v: u32) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// A byte reader that fails instead of panicking.
pub(crate) struct Reader<'a> {
    pub(crate) b: &'a [u8],
    pub(crate) at: usize,
}

impl Reader<'_> {
    pub(crate) fn err(&self) -> TableError {
        TableError::Length(self.b.len())
    }
    pub(crate) fn u8(&mut self) -> Result<u8, TableError> {
        let v = *self.b.get(self.at).ok_or_else(|| self.err())?;
        self.at += 1;
        Ok(v)
    }
    pub(crate) fn u16(&mut self) -> Result<u16, TableError> {
        Ok(u16::from_le_bytes([self.u8()?, self.u8()?]))
    }
    pub(crate) fn u32(&mut self) -> Result<u32, TableError> {
        Ok(u32::from_le_bytes([
            self.u8()?,
            self.u8()?,
            self.u8()?,
            self.u8()?,
        ]))
    }
    pub(crate) fn varint(&mut self) -> Result<u32, TableError> {
        let mut v: u64 = 0;
        for shift in (0..35).step_by(7) {
            let b = self.u8()?;
            v |= ((b & 0x7f) as u64) << shift;
            if b & 0x80 == 0 {
                return u32::try_from(v).map_err(|_| self.err());
            }
        }
        Err(self.err())
    }
}

/// Reads a pixel index list of `count` ascending, delta-coded indices below
/// `n`, calling `each(pixel, reader)` after each index.
pub(crate) fn read_pixels(
    r: &mut Reader,
    count: usize,
    n: u32,
    mut each: impl FnMut(u32, &mut Reader) -> Result<(), TableError>,
) -> Result<(), TableError> {
    let mut prev: Option<u32> = None;
    for _ in 0..count {
        let d = r.varint()?;
        let p = match prev {
            None => d,
            Some(q) => {
                if d == 0 {
                    return Err(r.err()); // not strictly ascending
                }
                q.checked_add(d).ok_or_else(|| r.err())?
            }
        };
        if p >= n {
            return Err(r.err());
        }
        prev = Some(p);
        each(p, r)?;
    }
    Ok(())
}

/// Node → manager: per changed pixel, the node's `L` level codes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PixelLevels {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Levels `L` (1..=16).
    pub levels: u8,
    /// The sender's screen footprint, inclusive pixel range `[x0, x1, y0,
    /// y1]` of every cell it has held (empty: `x0 > x1`): the manager's reply
    /// carries only the entries there.
    pub footprint: [u32; 4],
    /// Ascending pixel indices, each with `L` codes (level order).
    pub pixels: Vec<(u32, Vec<u16>)>,
}

const TAG_LEVELS: u8 = b'P';
const TAG_DEPTHS: u8 = b'D';

impl PixelLevels {
    /// Wire form: tag `P`, width and height (u32 LE), `L` (u8), the footprint
    /// (4 x u32 LE), count (u32 LE), then per pixel its index (varint delta from the previous one; the first
    /// absolute) and `L` codes (u16 LE).
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(14 + self.pixels.len() * (2 + 2 * self.levels as usize));
        out.push(TAG_LEVELS);
        out.extend_from_slice(&self.width.to_le_bytes());
        out.extend_from_slice(&self.height.to_le_bytes());
        out.push(self.levels);
        for v in self.footprint {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&(self.pixels.len() as u32).to_le_bytes());
        let mut prev = None;
        for (p, codes) in &self.pixels {
            put_varint(&mut out, prev.map_or(*p, |q: u32| p - q));
            prev = Some(*p);
            for c in codes {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        out
    }

    /// Decodes [`PixelLevels::encode`]'s form for a `width x height` image with
    /// `levels` levels; never panics, never allocates beyond the input's size.
    pub fn decode(bytes: &[u8], width: u32, height: u32, levels: u8) -> Result<Self, TableError> {
        let mut r = Reader { b: bytes, at: 0 };
        if r.u8()? != TAG_LEVELS {
            return Err(r.err());
        }
        let (w, h, l) = (r.u32()?, r.u32()?, r.u8()?);
        let footprint = [r.u32()?, r.u32()?, r.u32()?, r.u32()?];
        let count = r.u32()? as usize;
        let per = 1 + 2 * l as usize;
        if (w, h, l) != (width, height, levels) || count > bytes.len() / per.max(1) {
            return Err(TableError::Shape {
                got: (w.min(u16::MAX as u32) as u16, h.min(u16::MAX as u32) as u16),
                want: (
                    width.min(u16::MAX as u32) as u16,
                    height.min(u16::MAX as u32) as u16,
                ),
            });
        }
        let n = width.checked_mul(height).ok_or_else(|| r.err())?;
        let mut pixels = Vec::with_capacity(count);
        read_pixels(&mut r, count, n, |p, r| {
            let codes = (0..l).map(|_| r.u16()).collect::<Result<Vec<_>, _>>()?;
            pixels.push((p, codes));
            Ok(())
        })?;
        if r.at != bytes.len() {
            return Err(r.err());
        }
        Ok(PixelLevels {
            width,
            height,
            levels,
            footprint,
            pixels,
        })
    }
}

/// Manager → node: certified termination depths (codes) of the pixels whose
/// entry changed since the node's last reply. A pixel listed is terminated
/// at that depth (the paper's `terminated` bit and `deepest`, per pixel).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PixelDepths {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Ascending pixel indices with their certified depth codes.
    pub pixels: Vec<(u32, u16)>,
}

impl PixelDepths {
    /// Wire form: tag `D`, width and height (u32 LE), count (u32 LE), then per
    /// pixel its index (varint delta) and its code (u16 LE).
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(13 + self.pixels.len() * 4);
        out.push(TAG_DEPTHS);
        out.extend_from_slice(&self.width.to_le_bytes());
        out.extend_from_slice(&self.height.to_le_bytes());
        out.extend_from_slice(&(self.pixels.len() as u32).to_le_bytes());
        let mut prev = None;
        for (p, c) in &self.pixels {
            put_varint(&mut out, prev.map_or(*p, |q: u32| p - q));
            prev = Some(*p);
            out.extend_from_slice(&c.to_le_bytes());
        }
        out
    }

    /// Decodes [`PixelDepths::encode`]'s form for a `width x height` image;
    /// never panics.
    pub fn decode(bytes: &[u8], width: u32, height: u32) -> Result<Self, TableError> {
        let mut r = Reader { b: bytes, at: 0 };
        if r.u8()? != TAG_DEPTHS {
            return Err(r.err());
        }
        let (w, h) = (r.u32()?, r.u32()?);
        let count = r.u32()? as usize;
        if (w, h) != (width, height) || count > bytes.len() / 3 {
            return Err(r.err());
        }
        let n = width.checked_mul(height).ok_or_else(|| r.err())?;
        let mut pixels = Vec::with_capacity(count);
        read_pixels(&mut r, count, n, |p, r| {
            let c = r.u16()?;
            if c == NOT_REACHED {
                return Err(r.err());
            }
            pixels.push((p, c));
            Ok(())
        })?;
        if r.at != bytes.len() {
            return Err(r.err());
        }
        Ok(PixelDepths {
            width,
            height,
            pixels,
        })
    }
}

/// The `L`-th smallest code among `values` (`NOT_REACHED` if fewer than `L`
/// are reached): the certified termination depth of one pixel.
pub fn lth_smallest(values: &mut [u16], levels: usize) -> u16 {
    let reached = values.iter().filter(|&&c| c != NOT_REACHED).count();
    if levels == 0 || reached < levels {
        return NOT_REACHED;
    }
    let (_, nth, _) = values.select_nth_unstable(levels - 1);
    *nth
}

/// Edge of the manager's log tiles, in pixels: a reply walks the logs of the
/// tiles under the node's footprint only.
pub const TILE: u32 = 16;

/// The manager's store for per-pixel level sharing: every node's latest
/// codes per pixel, the certified depth per pixel, and a change log from
/// which each node's reply is cut.
#[derive(Debug, Clone)]
pub struct PixelStore {
    width: u32,
    height: u32,
    levels: usize,
    nodes: usize,
    /// `[pixel * L + i]`: the `L` smallest codes received for the pixel
    /// over all (node, level) pairs, ascending (`NOT_REACHED` where fewer),
    /// and whose they are (`node * 16 + level`; `u32::MAX`: empty slot).
    kept_code: Vec<u16>,
    kept_id: Vec<u32>,
    /// Per pixel, the certified depth code.
    certified: Vec<u16>,
    /// Per screen tile ([`TILE`] x [`TILE`] pixels), the pixels in the order
    /// their certified depth went down (repeats allowed).
    log: Vec<Vec<u32>>,
    /// Tiles per row.
    tiles_x: u32,
    /// `[node * tiles + tile]`: how much of the tile's log the node has been sent.
    cursor: Vec<usize>,
    /// Per node, its latest footprint.
    footprint: Vec<[u32; 4]>,
    /// Per pixel, the reply number that last listed it (dedupe).
    stamp: Vec<u32>,
    replies: u32,
}

impl PixelStore {
    /// An empty store for a `width x height` image, `levels` levels and
    /// `nodes` nodes.
    pub fn new(width: u32, height: u32, levels: usize, nodes: usize) -> PixelStore {
        let n = (width as usize) * (height as usize);
        let tiles_x = width.div_ceil(TILE).max(1);
        let tiles = (tiles_x * height.div_ceil(TILE).max(1)) as usize;
        PixelStore {
            width,
            height,
            levels,
            nodes,
            kept_code: vec![NOT_REACHED; n * levels],
            kept_id: vec![u32::MAX; n * levels],
            certified: vec![NOT_REACHED; n],
            log: vec![Vec::new(); tiles],
            tiles_x,
            cursor: vec![0; nodes * tiles],
            footprint: vec![[0, width.saturating_sub(1), 0, height.saturating_sub(1)]; nodes],
            stamp: vec![0; n],
            replies: 0,
        }
    }

    /// Image size and level count this store expects.
    pub fn shape(&self) -> (u32, u32, u8) {
        (self.width, self.height, self.levels as u8)
    }

    /// The certified depth code of every pixel.
    pub fn certified(&self) -> &[u16] {
        &self.certified
    }

    /// Applies node `k`'s codes (each lowers the node's value for that level
    /// and pixel) and recombines those pixels. Returns the work (slots
    /// compared), for the cost model.
    ///
    /// Only the `L` smallest (node, level) values per pixel are kept: values
    /// only ever go down, so one that has left the `L` smallest can come
    /// back only through a new, lower value — which its node sends.
    /// `O(L^2)` per pixel, whatever the node count.
    pub fn apply(&mut self, k: usize, d: &PixelLevels) -> Result<u64, TableError> {
        if k >= self.nodes
            || (d.width, d.height, d.levels as usize) != (self.width, self.height, self.levels)
        {
            return Err(TableError::Length(d.pixels.len()));
        }
        let l = self.levels;
        let mut work = 0u64;
        self.footprint[k] = d.footprint;
        for (p, codes) in &d.pixels {
            if codes.len() != l {
                return Err(TableError::Length(codes.len()));
            }
            let p = *p as usize;
            let kc = &mut self.kept_code[p * l..(p + 1) * l];
            let ki = &mut self.kept_id[p * l..(p + 1) * l];
            for (lvl, &c) in codes.iter().enumerate() {
                if c == NOT_REACHED {
                    continue;
                }
                let id = (k as u32) * 16 + lvl as u32;
                work += l as u64;
                let slot = match ki.iter().position(|&x| x == id) {
                    Some(i) if c < kc[i] => i,
                    Some(_) => continue,
                    None if c < kc[l - 1] => l - 1,
                    None => continue,
                };
                kc[slot] = c;
                ki[slot] = id;
                // Bubble the lowered value into place (the rest stays sorted).
                let mut i = slot;
                while i > 0 && kc[i - 1] > kc[i] {
                    kc.swap(i - 1, i);
                    ki.swap(i - 1, i);
                    i -= 1;
                }
            }
            let c = kc[l - 1];
            if c < self.certified[p] {
                self.certified[p] = c;
                let (x, y) = (p as u32 % self.width, p as u32 / self.width);
                self.log[((y / TILE) * self.tiles_x + x / TILE) as usize].push(p as u32);
            }
        }
        Ok(work)
    }

    /// The entries in the tiles under node `k`'s footprint that changed since its last
    /// reply (ascending pixel order, each once, with its current certified
    /// depth), and the work (log entries walked, entries packed).
    pub fn reply(&mut self, k: usize) -> (PixelDepths, u64) {
        self.replies = self.replies.wrapping_add(1).max(1);
        let mut pixels: Vec<(u32, u16)> = Vec::new();
        let mut work = 0u64;
        if k < self.nodes {
            let [x0, x1, y0, y1] = self.footprint[k];
            let (x1, y1) = (x1.min(self.width - 1), y1.min(self.height - 1));
            let tiles = self.log.len();
            if x0 <= x1 && y0 <= y1 {
                for ty in y0 / TILE..=y1 / TILE {
                    for tx in x0 / TILE..=x1 / TILE {
                        let t = (ty * self.tiles_x + tx) as usize;
                        let cur = &mut self.cursor[k * tiles + t];
                        let log = &self.log[t];
                        work += (log.len() - *cur) as u64;
                        // Whole tiles: a pixel left out now could not be sent
                        // later, once the cursor has passed it.
                        for &p in &log[*cur..] {
                            let s = &mut self.stamp[p as usize];
                            if *s != self.replies {
                                *s = self.replies;
                                pixels.push((p, self.certified[p as usize]));
                            }
                        }
                        *cur = log.len();
                    }
                }
            }
        }
        pixels.sort_unstable_by_key(|e| e.0);
        work += pixels.len() as u64;
        (
            PixelDepths {
                width: self.width,
                height: self.height,
                pixels,
            },
            work,
        )
    }
}

/// A node's side of per-pixel level sharing: its own per-pixel level depths
/// (cached minima), the pixels not yet sent, and the depth codes.
#[derive(Debug, Clone)]
pub struct NodePixelLevels {
    /// The level opacities `a_1 < ... < a_L = thr`.
    pub alphas: Vec<f32>,
    /// `[pixel * L + l]`: own depth where level `l` was reached (`+inf`: not yet).
    pub pix: Vec<f32>,
    /// Depth codes.
    pub quant: DepthQuant,
    unsent_flag: Vec<bool>,
    /// Per manager shard, the changed pixels it owns not yet sent.
    unsent: Vec<Vec<u32>>,
    shards: ShardMap,
    width: u32,
}

impl NodePixelLevels {
    /// For a `width x height` image, threshold `thr`, `levels` levels.
    pub fn new(width: u32, height: u32, thr: f32, levels: usize, quant: DepthQuant) -> Self {
        let n = (width as usize) * (height as usize);
        let alphas = level_alphas(thr, levels.clamp(1, 16));
        NodePixelLevels {
            pix: vec![f32::INFINITY; n * alphas.len()],
            alphas,
            quant,
            unsent_flag: vec![false; n],
            unsent: vec![Vec::new()],
            shards: ShardMap::single(),
            width,
        }
    }

    /// Splits the pixels to send by manager shard (`map`, for this image);
    /// call before the first update.
    pub fn set_shards(&mut self, map: ShardMap) {
        let mut all: Vec<u32> = self.unsent.drain(..).flatten().collect();
        all.sort_unstable();
        self.shards = map;
        self.unsent = vec![Vec::new(); map.count()];
        for p in all {
            self.unsent[map.shard_of_pixel(p, self.width)].push(p);
        }
    }

    /// The manager shards' map.
    pub fn shards(&self) -> &ShardMap {
        &self.shards
    }

    /// Number of levels.
    pub fn levels(&self) -> usize {
        self.alphas.len()
    }

    /// Notes that pixel `p`'s level depths changed.
    #[inline]
    pub fn mark(&mut self, p: usize) {
        if !self.unsent_flag[p] {
            self.unsent_flag[p] = true;
            let s = self.shards.shard_of_pixel(p as u32, self.width);
            self.unsent[s].push(p as u32);
        }
    }

    /// Takes the changed pixels of manager shard `shard` as a
    /// [`PixelLevels`] share with the sender's `footprint`; also returns how
    /// many codes were packed.
    pub fn take(
        &mut self,
        shard: usize,
        width: u32,
        height: u32,
        footprint: [u32; 4],
    ) -> (PixelLevels, u64) {
        let l = self.levels();
        let mut ids = self
            .unsent
            .get_mut(shard)
            .map(std::mem::take)
            .unwrap_or_default();
        ids.sort_unstable();
        let pixels: Vec<(u32, Vec<u16>)> = ids
            .iter()
            .map(|&p| {
                self.unsent_flag[p as usize] = false;
                let v = &self.pix[p as usize * l..(p as usize + 1) * l];
                (p, v.iter().map(|&z| self.quant.up(z)).collect())
            })
            .collect();
        let packed = (pixels.len() * l) as u64;
        (
            PixelLevels {
                width,
                height,
                levels: l as u8,
                footprint,
                pixels,
            },
            packed,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn codes_round_up(z0 in -500.0f32..500.0, span in 0.001f32..2000.0, t in -0.2f32..1.2) {
            let q = DepthQuant::new(z0, z0 + span);
            let z = z0 + t * span;
            let c = q.up(z);
            prop_assert!(q.value(c) >= z, "code {} value {} < {}", c, q.value(c), z);
            if (0.0..=1.0).contains(&t) {
                prop_assert!(c != NOT_REACHED);
                // Tight: one step less would be below z (unless the step is
                // below f32 resolution there and both codes decode alike).
                if c > 0 {
                    prop_assert!(q.value(c - 1) < z || q.value(c - 1) == q.value(c));
                }
            }
        }

        #[test]
        fn pixel_levels_round_trip(
            levels in 1u8..6,
            raw in proptest::collection::btree_map(0u32..600, proptest::collection::vec(any::<u16>(), 5), 0..50),
        ) {
            let d = PixelLevels {
                width: 30,
                height: 20,
                levels,
                footprint: [1, 20, 3, 19],
                pixels: raw.into_iter().map(|(p, v)| (p, v[..levels as usize].to_vec())).collect(),
            };
            let b = d.encode();
            prop_assert_eq!(PixelLevels::decode(&b, 30, 20, levels).unwrap(), d);
        }

        #[test]
        fn decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
            let _ = PixelLevels::decode(&bytes, 30, 20, 3);
            let _ = PixelDepths::decode(&bytes, 30, 20);
        }

        /// The store's certified depth is the L-th smallest of the latest
        /// codes of all nodes, whatever the order the shares arrive in, and
        /// every reply sequence brings a node exactly the final certified
        /// values of the pixels that changed.
        #[test]
        fn store_combines_like_the_definition(
            shares in proptest::collection::vec((0usize..3, 0u32..12, proptest::collection::vec(0u16..50, 2)), 1..40),
        ) {
            let mut s = PixelStore::new(4, 3, 2, 3);
            let mut latest = vec![vec![vec![NOT_REACHED; 2]; 3]; 12]; // [pixel][node][level]
            let mut seen = [NOT_REACHED; 12];
            for (k, p, mut codes) in shares {
                codes.sort_unstable(); // a node's levels are nondecreasing
                for (old, new) in latest[p as usize][k].iter_mut().zip(&codes) {
                    *old = (*old).min(*new);
                }
                let d = PixelLevels { width: 4, height: 3, levels: 2, footprint: [0, 3, 0, 2], pixels: vec![(p, codes)] };
                s.apply(k, &d).unwrap();
                let (r, _) = s.reply(0);
                for (p, c) in r.pixels {
                    prop_assert!(c < seen[p as usize]);
                    seen[p as usize] = c;
                }
            }
            for p in 0..12 {
                let mut all: Vec<u16> = latest[p].iter().flatten().copied().collect();
                let want = lth_smallest(&mut all, 2);
                prop_assert_eq!(s.certified()[p], want);
                prop_assert_eq!(seen[p], want);
            }
        }
    }

    #[test]
    fn forged_counts_and_unordered_pixels_are_errors() {
        let d = PixelDepths {
            width: 4,
            height: 4,
            pixels: vec![(3, 7), (9, 1)],
        };
        let mut b = d.encode();
        assert_eq!(PixelDepths::decode(&b, 4, 4).unwrap(), d);
        assert!(PixelDepths::decode(&b, 4, 5).is_err());
        b[9..13].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(PixelDepths::decode(&b, 4, 4).is_err());
        let bad = PixelDepths {
            width: 4,
            height: 4,
            pixels: vec![(3, 7), (3, 1)],
        };
        assert!(PixelDepths::decode(&bad.encode(), 4, 4).is_err());
        let out = PixelDepths {
            width: 4,
            height: 4,
            pixels: vec![(16, 7)],
        };
        assert!(PixelDepths::decode(&out.encode(), 4, 4).is_err());
    }

    /// A reply carries only the changes under the node's footprint; a node
    /// whose footprint grows gets the whole history of the new part.
    #[test]
    fn replies_follow_the_footprint() {
        let mut s = PixelStore::new(40, 40, 1, 2);
        let share = |fp: [u32; 4], px: &[u32]| PixelLevels {
            width: 40,
            height: 40,
            levels: 1,
            footprint: fp,
            pixels: px.iter().map(|&p| (p, vec![5])).collect(),
        };
        // Node 1 terminates pixels (1, 1) and (35, 35).
        s.apply(1, &share([0, 39, 0, 39], &[41, 35 * 40 + 35]))
            .unwrap();
        // Node 0 covers only the top-left corner.
        s.apply(0, &share([0, 9, 0, 9], &[])).unwrap();
        assert_eq!(s.reply(0).0.pixels, vec![(41, 5)]);
        assert!(s.reply(0).0.pixels.is_empty());
        // Its footprint grows to the whole screen: the rest arrives.
        s.apply(0, &share([0, 39, 0, 39], &[])).unwrap();
        assert_eq!(s.reply(0).0.pixels, vec![(35 * 40 + 35, 5)]);
    }

    #[test]
    fn lth_smallest_counts_units() {
        assert_eq!(lth_smallest(&mut [5, NOT_REACHED, 3], 2), 5);
        assert_eq!(
            lth_smallest(&mut [5, NOT_REACHED, NOT_REACHED], 2),
            NOT_REACHED
        );
        assert_eq!(lth_smallest(&mut [], 1), NOT_REACHED);
    }
}
