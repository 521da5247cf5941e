//! A node's side of per-pixel level sharing ([`NodePixelLevels`]): its own
//! per-pixel level depths, the changed pixels not yet sent (per manager
//! shard), and the share message cut from them.

use super::quant::DepthQuant;
use super::wire::PixelLevels;
use crate::node::levels::level_alphas;
use crate::node::shard_map::ShardMap;

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
