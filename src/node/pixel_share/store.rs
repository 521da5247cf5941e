//! The manager's side: [`PixelStore`] keeps every node's latest level codes
//! per pixel, certifies a pixel at the `L`-th smallest of them
//! ([`lth_smallest`]) and cuts each node's reply from a per-tile change log.

use super::quant::NOT_REACHED;
use super::wire::{PixelDepths, PixelLevels};
use crate::node::table::TableError;

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

pub use crate::node::shard_map::TILE;

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
