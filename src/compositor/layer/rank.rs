//! One rank of the layer kind ([`LayerRank`], a [`RankPartial`]) and the
//! root's gather ([`LayerGather`]): the steps the in-process executor
//! ([`super::exec::run`]) and phase 2 worker to worker both run, so their
//! images are the same bit for bit.
//!
//! Received bytes are untrusted (peers): a layer message must be for the
//! receiver's kept region, every layer inside it, decoded with at most its
//! area of pixels, visibility ranks below the brick count and not
//! overlapping (checked when composited); a gathered piece must lie inside
//! the screen. The root's own piece reaches the coordinator as raw f32
//! (`x0 y0 x1 y1` in the phase-2 header, then `4 · area` f32 LE), so the
//! hand-off adds no rounding.

use crate::base::Rect;
use crate::compositor::codec::layers::LayerCodec;
use crate::compositor::exec::Message;
use crate::compositor::partial::{Encoded, MergeCounts, RankPartial};
use crate::compositor::region::{area, contains};
use crate::compositor::schedule::Payload;
use crate::image::Image;

use super::message::{decode_within, encode};
use super::{composite, merge_adjacent, Layer};

/// One rank's layers through a schedule.
pub struct LayerRank<'a> {
    codec: &'a dyn LayerCodec,
    merge_early: bool,
    /// Visibility ranks are below this (the brick count).
    ranks: u32,
    held: Vec<Layer>,
    region: Option<Rect>,
    piece: Option<(Rect, Vec<[f32; 4]>)>,
}

impl<'a> LayerRank<'a> {
    /// A rank holding `layers` over `image` (visibility ranks below
    /// `ranks`); with `merge_early`, rank-adjacent layers are composited
    /// after each lists round (radix-k).
    pub fn new(
        codec: &'a dyn LayerCodec,
        image: Rect,
        layers: Vec<Layer>,
        ranks: u32,
        merge_early: bool,
    ) -> LayerRank<'a> {
        LayerRank {
            codec,
            merge_early,
            ranks,
            held: layers,
            region: Some(image),
            piece: None,
        }
    }
}

impl RankPartial for LayerRank<'_> {
    fn encode(&self, what: Payload) -> anyhow::Result<Option<Encoded>> {
        match what {
            Payload::Lists(r) => {
                let part: Vec<Layer> = self
                    .held
                    .iter()
                    .map(|l| l.crop(&r))
                    .filter(|l| area(&l.rect) > 0)
                    .collect();
                let (bytes, raw_bytes) = encode(self.codec, &part);
                Ok(Some(Encoded {
                    bytes,
                    raw_bytes,
                    pixels: part.iter().map(|l| l.px.len() as u64).sum(),
                }))
            }
            Payload::Pixels(r) => {
                let Some((pr, px)) = &self.piece else {
                    return Ok(None);
                };
                anyhow::ensure!(
                    *pr == r,
                    "the schedule gathers {r:?}, this rank composited {pr:?}"
                );
                let l = Layer::quantize(r, 0, self.codec.depth(), px);
                let (bytes, raw_bytes) = encode(self.codec, std::slice::from_ref(&l));
                Ok(Some(Encoded {
                    bytes,
                    raw_bytes,
                    pixels: l.px.len() as u64,
                }))
            }
        }
    }

    fn keep(&mut self, keep: Option<Rect>) {
        self.held = match keep {
            Some(r) => self
                .held
                .iter()
                .map(|l| l.crop(&r))
                .filter(|l| area(&l.rect) > 0)
                .collect(),
            None => Vec::new(),
        };
        self.region = keep;
    }

    fn merge(&mut self, got: &[Message]) -> anyhow::Result<MergeCounts> {
        for m in got {
            let Payload::Lists(r) = m.what else {
                anyhow::bail!("rank {} sent pixels in a lists round", m.from);
            };
            anyhow::ensure!(
                self.region == Some(r),
                "rank {} sent layers of {r:?} to rank {}, which keeps {:?}",
                m.from,
                m.to,
                self.region
            );
            let layers = decode_within(self.codec, &m.bytes, &r)
                .map_err(|e| anyhow::anyhow!("layers from rank {}: {e}", m.from))?;
            for l in &layers {
                anyhow::ensure!(
                    l.ranks[0] <= l.ranks[1] && l.ranks[1] < self.ranks,
                    "rank {} sent a layer of visibility ranks {:?} ({} bricks)",
                    m.from,
                    l.ranks,
                    self.ranks
                );
            }
            self.held.extend(layers);
        }
        let mut c = MergeCounts::default();
        if self.merge_early {
            let (m, px) =
                merge_adjacent(std::mem::take(&mut self.held)).map_err(|e| anyhow::anyhow!(e))?;
            self.held = m;
            c.blended = px;
        }
        Ok(c)
    }

    fn composite(&mut self) -> anyhow::Result<Option<(u64, u64)>> {
        let held = std::mem::take(&mut self.held);
        let Some(r) = self.region.take() else {
            return Ok(None);
        };
        if held.is_empty() {
            return Ok(None); // nothing to blend: its region stays transparent
        }
        let refs: Vec<&Layer> = held.iter().collect();
        let px = composite(&r, &refs).map_err(|e| anyhow::anyhow!(e))?;
        self.piece = Some((r, px));
        Ok(Some((
            held.iter().map(|l| l.px.len() as u64).sum(),
            held.len() as u64,
        )))
    }

    fn handoff(&mut self) -> Vec<(Rect, Vec<u8>)> {
        self.piece
            .take()
            .map(|(r, px)| {
                let mut b = Vec::with_capacity(16 * px.len());
                for p in &px {
                    for c in p {
                        b.extend_from_slice(&c.to_le_bytes());
                    }
                }
                (r, b)
            })
            .into_iter()
            .collect()
    }
}

/// The root's image: gathered pieces pasted over a transparent screen.
pub struct LayerGather<'a> {
    codec: &'a dyn LayerCodec,
    image: Rect,
    out: Vec<[f32; 4]>,
}

impl<'a> LayerGather<'a> {
    /// An empty screen `image`.
    pub fn new(codec: &'a dyn LayerCodec, image: Rect) -> LayerGather<'a> {
        LayerGather {
            codec,
            image,
            out: vec![[0.0; 4]; area(&image)],
        }
    }

    fn paste(&mut self, r: &Rect, px: &[[f32; 4]]) {
        let w = self.image.width() as usize;
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                self.out[(y - self.image.y0) as usize * w + (x - self.image.x0) as usize] =
                    px[((y - r.y0) * r.width() + (x - r.x0)) as usize];
            }
        }
    }

    /// A gathered piece of `rect`: a layer message (one layer inside it).
    pub fn take(&mut self, rect: Rect, bytes: &[u8]) -> anyhow::Result<()> {
        anyhow::ensure!(
            contains(&self.image, &rect),
            "a gathered piece {rect:?} outside the screen {:?}",
            self.image
        );
        for got in decode_within(self.codec, bytes, &rect)? {
            self.paste(&got.rect, &got.to_f32());
        }
        Ok(())
    }

    /// The root's own piece of `rect` in the hand-off form (raw f32).
    pub fn take_handoff(&mut self, rect: Rect, bytes: &[u8]) -> anyhow::Result<()> {
        anyhow::ensure!(
            contains(&self.image, &rect),
            "the root's piece {rect:?} outside the screen {:?}",
            self.image
        );
        anyhow::ensure!(
            bytes.len() as u64 == 16 * area(&rect) as u64,
            "the root's piece of {rect:?}: {} bytes, not 16 per pixel",
            bytes.len()
        );
        let px: Vec<[f32; 4]> = bytes
            .chunks_exact(16)
            .map(|c| {
                let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
                [f(0), f(4), f(8), f(12)]
            })
            .collect();
        anyhow::ensure!(
            px.iter().flatten().all(|v| v.is_finite()),
            "the root's piece of {rect:?} holds a value that is not finite"
        );
        self.paste(&rect, &px);
        Ok(())
    }

    /// The image over `background`.
    pub fn image(&self, background: [f32; 3]) -> Image {
        let mut image = Image::new(self.image.width(), self.image.height());
        for (o, p) in image.pixels.iter_mut().zip(&self.out) {
            let t = 1.0 - p[3];
            *o = [
                p[0] + t * background[0],
                p[1] + t * background[1],
                p[2] + t * background[2],
                p[3],
            ];
        }
        image
    }
}
