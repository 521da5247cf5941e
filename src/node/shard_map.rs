//! Which manager shard owns which screen tile (per-pixel ERT sharing with
//! a sharded manager, `pvrsim cluster --manager-shards K`).
//!
//! The screen is cut into the manager's log tiles ([`TILE`] x [`TILE`]
//! pixels, `tx in 0..tiles_x`, `ty in 0..tiles_y`), and tile `(tx, ty)`
//! belongs to shard
//!
//! ```text
//! s(tx, ty) = (tx + ty * r) mod K,      r = ceil(sqrt(K)),
//! ```
//!
//! a lattice: with `K = r^2` every `r x r` window of tiles holds every shard
//! once (`K = 16`: 4 x 4 windows of 64 x 64 pixels). So the ERT traffic,
//! which follows the projected volume wherever it lies on the screen, is
//! spread evenly over the shards without knowing the view, and a node whose
//! footprint covers `w x h` tiles talks to at most `min(K, w h)` shards.
//! Should the lattice leave a shard without a tile (a screen only a few
//! tiles wide), the row-major interleave `(tx + ty * tiles_x) mod K` is used
//! instead, which gives every shard a tile whenever `K <= tiles`.
//!
//! Shard `s` runs at rank `manager + s`; shard 0 is the manager itself
//! (load balancing, the end of phase 1), so with `K = 1` the protocol is
//! the unsharded one exactly.

/// Edge of the manager's log tiles, in pixels: a reply walks the logs of the
/// tiles under the node's footprint only.
pub const TILE: u32 = 16;

/// The tile-to-shard map of a run. `K = 1`: one shard, the manager.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShardMap {
    k: u32,
    tiles_x: u32,
    tiles_y: u32,
    /// Shard offset from one tile row to the next.
    stride: u32,
}

/// Nodes up to which one manager (no sharding) is the default.
pub const NODES_PER_SHARD: usize = 16;

impl ShardMap {
    /// One shard (the unsharded manager).
    pub fn single() -> ShardMap {
        ShardMap {
            k: 1,
            tiles_x: 1,
            tiles_y: 1,
            stride: 0,
        }
    }

    /// The default shard count for `nodes` nodes: one manager up to
    /// [`NODES_PER_SHARD`] nodes, then one shard per [`NODES_PER_SHARD`]
    /// nodes (`ceil(N / 16)`: 2 at 32 nodes, 4 at 64, 16 at 256), at most
    /// `tiles`.
    pub fn default_count(nodes: usize, tiles: usize) -> usize {
        nodes.div_ceil(NODES_PER_SHARD).clamp(1, tiles.max(1))
    }

    /// Screen tiles of a `width x height` image.
    pub fn tiles(width: u32, height: u32) -> usize {
        (width.div_ceil(TILE).max(1) as usize) * (height.div_ceil(TILE).max(1) as usize)
    }

    /// `k` shards over a `width x height` image. Errors (naming the option)
    /// if `k < 1` or `k` exceeds the number of screen tiles.
    pub fn new(width: u32, height: u32, k: usize) -> Result<ShardMap, String> {
        let tiles = Self::tiles(width, height);
        if k < 1 || k > tiles {
            return Err(format!(
                "--manager-shards must be between 1 and the number of {TILE}x{TILE} screen \
                 tiles ({tiles} for {width}x{height}), got {k}"
            ));
        }
        let (tiles_x, tiles_y) = (width.div_ceil(TILE).max(1), height.div_ceil(TILE).max(1));
        let k = k as u32;
        let r = (1..=k).find(|r| r * r >= k).unwrap_or(1);
        let mut m = ShardMap {
            k,
            tiles_x,
            tiles_y,
            stride: r % k,
        };
        if m.tile_counts().contains(&0) {
            m.stride = tiles_x % k;
        }
        debug_assert!(!m.tile_counts().contains(&0));
        Ok(m)
    }

    /// Number of shards `K`.
    pub fn count(&self) -> usize {
        self.k as usize
    }

    /// The shard owning tile `(tx, ty)`.
    #[inline]
    pub fn shard_of_tile(&self, tx: u32, ty: u32) -> usize {
        if self.k == 1 {
            return 0;
        }
        ((tx as u64 + ty as u64 * self.stride as u64) % self.k as u64) as usize
    }

    /// The shard owning pixel `p` of an image `width` pixels wide.
    #[inline]
    pub fn shard_of_pixel(&self, p: u32, width: u32) -> usize {
        if self.k == 1 {
            return 0;
        }
        self.shard_of_tile((p % width) / TILE, (p / width) / TILE)
    }

    /// Tiles per shard.
    pub fn tile_counts(&self) -> Vec<usize> {
        let mut c = vec![0; self.k as usize];
        for ty in 0..self.tiles_y {
            for tx in 0..self.tiles_x {
                c[self.shard_of_tile(tx, ty)] += 1;
            }
        }
        c
    }

    /// Per shard, whether a tile of it lies under the inclusive pixel range
    /// `[x0, x1, y0, y1]` (empty range: none). Shard 0 is always included
    /// (it is the manager: load reports travel with its shares).
    pub fn touched(&self, footprint: [u32; 4]) -> Vec<bool> {
        let mut t = vec![false; self.k as usize];
        t[0] = true;
        let [x0, x1, y0, y1] = footprint;
        if self.k == 1 || x0 > x1 || y0 > y1 {
            return t;
        }
        let (tx1, ty1) = (
            (x1 / TILE).min(self.tiles_x - 1),
            (y1 / TILE).min(self.tiles_y - 1),
        );
        let mut left = self.k as usize - 1;
        'rows: for ty in (y0 / TILE)..=ty1 {
            for tx in (x0 / TILE)..=tx1 {
                let s = self.shard_of_tile(tx, ty);
                if !t[s] {
                    t[s] = true;
                    left -= 1;
                    if left == 0 {
                        break 'rows;
                    }
                }
            }
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn bad_counts_are_errors() {
        assert!(ShardMap::new(300, 300, 0).is_err());
        // 19 x 19 tiles.
        assert!(ShardMap::new(300, 300, 361).is_ok());
        let e = ShardMap::new(300, 300, 362).unwrap_err();
        assert!(e.contains("--manager-shards") && e.contains("361"), "{e}");
    }

    #[test]
    fn sixteen_shards_form_a_lattice() {
        let m = ShardMap::new(300, 300, 16).unwrap();
        for ty in 0..15 {
            for tx in 0..15 {
                let mut seen = [false; 16];
                for dy in 0..4 {
                    for dx in 0..4 {
                        seen[m.shard_of_tile(tx + dx, ty + dy)] = true;
                    }
                }
                assert!(seen.iter().all(|&s| s), "window at ({tx}, {ty})");
            }
        }
        let c = m.tile_counts();
        assert_eq!(c.iter().sum::<usize>(), 361);
        // 19 x 19 tiles: a 4 x 4 lattice gives each shard 19 to 24 of them.
        assert!(c.iter().all(|&n| (19..=24).contains(&n)), "{c:?}");
    }

    #[test]
    fn default_count_follows_the_node_count() {
        assert_eq!(ShardMap::default_count(1, 361), 1);
        assert_eq!(ShardMap::default_count(16, 361), 1);
        assert_eq!(ShardMap::default_count(32, 361), 2);
        assert_eq!(ShardMap::default_count(256, 361), 16);
        assert_eq!(ShardMap::default_count(256, 4), 4);
    }

    proptest! {
        /// Every shard owns a tile for every valid K; `touched` is exactly
        /// the set of shards owning a tile under the range (plus shard 0).
        #[test]
        fn every_shard_owns_a_tile_and_touched_is_exact(
            w in 1u32..200, h in 1u32..200, kf in 0.0f64..1.0,
            x0 in 0u32..220, x1 in 0u32..220, y0 in 0u32..220, y1 in 0u32..220,
        ) {
            let tiles = ShardMap::tiles(w, h);
            let k = 1 + (kf * (tiles - 1) as f64) as usize;
            let m = ShardMap::new(w, h, k).unwrap();
            prop_assert!(!m.tile_counts().contains(&0), "k {} w {} h {}", k, w, h);
            let t = m.touched([x0, x1, y0, y1]);
            let mut want = vec![false; k];
            want[0] = true;
            for y in y0..=y1.min(h - 1) {
                for x in x0..=x1.min(w - 1) {
                    want[m.shard_of_pixel(y * w + x, w)] = true;
                }
            }
            if x0 <= x1 && y0 <= y1 && x0 < w && y0 < h {
                prop_assert_eq!(t, want);
            }
        }
    }
}
