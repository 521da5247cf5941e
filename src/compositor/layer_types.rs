//! The layer types shared by the layer strategies ([`crate::compositor::layer`])
//! and the layer codecs ([`crate::compositor::codec::layers`]): a brick's
//! fixed-point RGBA subimage ([`Layer`]) and its bits per channel
//! ([`Depth`]). Kept apart so that the codecs need not name the layer
//! strategies that use them; `compositor::layer` re-exports all of it.

use crate::base::Rect;

use super::region::area;

/// Bits per channel of a layer's pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Depth {
    /// 8 bits a channel (RGBA8, the paper's subimages).
    U8,
    /// 16 bits a channel (RGBA16).
    U16,
}

impl Depth {
    /// The largest channel value `M = 2^bits - 1` (it stands for 1.0).
    #[inline]
    pub fn max(self) -> u16 {
        match self {
            Depth::U8 => 255,
            Depth::U16 => 65535,
        }
    }

    /// Bytes a channel.
    #[inline]
    pub fn channel_bytes(self) -> usize {
        match self {
            Depth::U8 => 1,
            Depth::U16 => 2,
        }
    }

    /// Bytes a pixel (four channels).
    #[inline]
    pub fn pixel_bytes(self) -> usize {
        4 * self.channel_bytes()
    }

    /// Rounds a premultiplied `[0, 1]` channel to `round(v M)`.
    #[inline]
    pub fn quantize(self, v: f32) -> u16 {
        (v.clamp(0.0, 1.0) * self.max() as f32 + 0.5) as u16
    }

    /// The value a channel stands for, `q / M`.
    #[inline]
    pub fn value(self, q: u16) -> f32 {
        q as f32 / self.max() as f32
    }
}

/// One brick's (or a run of adjacent bricks') premultiplied RGBA subimage.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layer {
    /// The screen rectangle the pixels cover (row-major inside it).
    pub rect: Rect,
    /// Inclusive range of visibility ranks (0 = nearest the eye).
    pub ranks: [u32; 2],
    /// Bits per channel; every value in `px` is at most `depth.max()`.
    pub depth: Depth,
    /// Premultiplied RGBA at `depth`, `area(rect)` of them.
    pub px: Vec<[u16; 4]>,
}

/// Rounds a premultiplied `[0, 1]` channel to 8 bits (nearest).
#[inline]
pub fn to_u8(v: f32) -> u8 {
    Depth::U8.quantize(v) as u8
}

impl Layer {
    /// An empty (all transparent) layer.
    pub fn empty(rect: Rect, rank: u32, depth: Depth) -> Layer {
        Layer {
            rect,
            ranks: [rank, rank],
            depth,
            px: vec![[0; 4]; area(&rect)],
        }
    }

    /// Quantises premultiplied f32 pixels (row-major over `rect`) to `depth`.
    pub fn quantize(rect: Rect, rank: u32, depth: Depth, px: &[[f32; 4]]) -> Layer {
        debug_assert_eq!(px.len(), area(&rect));
        Layer {
            rect,
            ranks: [rank, rank],
            depth,
            px: px.iter().map(|p| p.map(|c| depth.quantize(c))).collect(),
        }
    }

    /// The pixels as premultiplied f32 (`q / M`).
    pub fn to_f32(&self) -> Vec<[f32; 4]> {
        let d = self.depth;
        self.px.iter().map(|p| p.map(|q| d.value(q))).collect()
    }

    /// The part of the layer inside `r` (clipped to the layer's rectangle).
    pub fn crop(&self, r: &Rect) -> Layer {
        let c = intersect(&self.rect, r);
        let mut px = Vec::with_capacity(area(&c));
        let w = self.rect.width() as usize;
        // An empty intersection may be anchored outside the layer's columns
        // (x0 past its right edge): no rows to copy then.
        let rows = if c.x1 > c.x0 { c.y0..c.y1 } else { 0..0 };
        for y in rows {
            let row = (y - self.rect.y0) as usize * w;
            let a = row + (c.x0 - self.rect.x0) as usize;
            let b = row + (c.x1 - self.rect.x0) as usize;
            px.extend_from_slice(&self.px[a..b]);
        }
        Layer {
            rect: c,
            ranks: self.ranks,
            depth: self.depth,
            px,
        }
    }

    /// Bytes of the pixels at their depth (the raw size without header).
    pub fn raw_bytes(&self) -> u64 {
        (self.depth.pixel_bytes() * self.px.len()) as u64
    }
}

/// The intersection of two rectangles (empty, anchored at `a`'s corner
/// clamped into `b`, when they do not overlap).
pub fn intersect(a: &Rect, b: &Rect) -> Rect {
    let x0 = a.x0.max(b.x0);
    let y0 = a.y0.max(b.y0);
    let x1 = a.x1.min(b.x1).max(x0);
    let y1 = a.y1.min(b.y1).max(y0);
    Rect { x0, y0, x1, y1 }
}
