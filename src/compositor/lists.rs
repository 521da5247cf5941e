//! A node's contribution to a screen region: per pixel a list of ray
//! segments in canonical form (`canonical`), stored
//! compactly (one flat segment array plus per-pixel offsets); and the RGBA
//! pixels a region composites to.

use crate::base::segment::{Rgba, Segment};
use crate::base::Rect;

use super::canonical;
use super::region::{area, contains};

/// Segment lists of the pixels of `rect`, row-major, each list in canonical
/// form (sorted by [`canonical::order`], no clear segments, and with partial
/// composition its chains cut into maximal early-mergeable pieces).
#[derive(Debug, Clone, PartialEq)]
pub struct RegionLists {
    rect: Rect,
    /// `start[p]..start[p + 1]` indexes `segs` for local pixel `p`.
    start: Vec<usize>,
    segs: Vec<Segment>,
}

/// Two regions that should describe the same pixels do not.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("region mismatch: {0:?} is not {1:?}")]
pub struct RegionMismatch(pub Rect, pub Rect);

impl RegionLists {
    /// No segments anywhere in `rect`.
    pub fn empty(rect: Rect) -> RegionLists {
        RegionLists {
            rect,
            start: vec![0; area(&rect) + 1],
            segs: Vec::new(),
        }
    }

    /// Builds the lists of `rect` from `pixel(x, y)` (screen coordinates),
    /// which must already be canonical (e.g. produced by [`canonical::insert`]).
    pub fn from_canonical_fn<'a>(
        rect: Rect,
        mut pixel: impl FnMut(u32, u32) -> &'a [Segment],
    ) -> RegionLists {
        let mut out = RegionLists {
            rect,
            start: Vec::with_capacity(area(&rect) + 1),
            segs: Vec::new(),
        };
        out.start.push(0);
        for y in rect.y0..rect.y1 {
            for x in rect.x0..rect.x1 {
                out.segs.extend_from_slice(pixel(x, y));
                out.start.push(out.segs.len());
            }
        }
        out
    }

    /// Canonicalises arbitrary per-pixel segments (row-major over `rect`,
    /// any order): each pixel's segments inserted with [`canonical::insert`].
    ///
    /// # Panics
    /// If `raw.len()` is not the area of `rect`.
    pub fn canonical(rect: Rect, raw: &[Vec<Segment>], partial: bool) -> RegionLists {
        assert_eq!(raw.len(), area(&rect), "one list per pixel of {rect:?}");
        let mut start = Vec::with_capacity(raw.len() + 1);
        let mut segs = Vec::new();
        let mut scratch = Vec::new();
        start.push(0);
        for list in raw {
            scratch.clear();
            for s in list {
                canonical::insert(&mut scratch, *s, partial);
            }
            segs.extend_from_slice(&scratch);
            start.push(segs.len());
        }
        RegionLists { rect, start, segs }
    }

    /// The region.
    pub fn rect(&self) -> Rect {
        self.rect
    }

    /// Pixels in the region.
    pub fn pixels(&self) -> usize {
        self.start.len() - 1
    }

    /// The list of local pixel `p` (row-major in the region).
    #[inline]
    pub fn list(&self, p: usize) -> &[Segment] {
        &self.segs[self.start[p]..self.start[p + 1]]
    }

    /// All segments, pixel after pixel.
    pub fn segments(&self) -> &[Segment] {
        &self.segs
    }

    /// Pixels with a non-empty list.
    pub fn covered(&self) -> usize {
        self.start.windows(2).filter(|w| w[1] > w[0]).count()
    }

    /// The lists of `sub`, a part of this region.
    ///
    /// # Panics
    /// If `sub` is not inside the region.
    pub fn sub(&self, sub: Rect) -> RegionLists {
        assert!(
            contains(&self.rect, &sub),
            "{sub:?} not inside {:?}",
            self.rect
        );
        let w = self.rect.width() as usize;
        Self::from_canonical_fn(sub, |x, y| {
            self.list((y - self.rect.y0) as usize * w + (x - self.rect.x0) as usize)
        })
    }

    /// Merges `other` (same region) into these lists, pixel by pixel, with
    /// [`canonical::merge`]. Returns `(pixel merges, entries removed by
    /// partial composition)`.
    pub fn merge(
        &mut self,
        other: &RegionLists,
        partial: bool,
    ) -> Result<(u64, u64), RegionMismatch> {
        if other.rect != self.rect {
            return Err(RegionMismatch(other.rect, self.rect));
        }
        if other.segs.is_empty() {
            return Ok((0, 0));
        }
        let (mut merges, mut removed) = (0u64, 0u64);
        let mut segs = Vec::with_capacity(self.segs.len() + other.segs.len());
        let mut start = Vec::with_capacity(self.start.len());
        let mut scratch = Vec::new();
        start.push(0);
        for p in 0..self.pixels() {
            let (a, b) = (self.list(p), other.list(p));
            if a.is_empty() || b.is_empty() {
                segs.extend_from_slice(a);
                segs.extend_from_slice(b);
            } else {
                merges += 1;
                removed += canonical::merge(a, b, partial, &mut scratch) as u64;
                segs.extend_from_slice(&scratch);
            }
            start.push(segs.len());
        }
        self.segs = segs;
        self.start = start;
        Ok((merges, removed))
    }

    /// Final composition of every pixel ([`canonical::composite`]), without
    /// the background.
    pub fn composite(&self) -> RegionPixels {
        RegionPixels {
            rect: self.rect,
            px: (0..self.pixels())
                .map(|p| canonical::composite(self.list(p)))
                .collect(),
        }
    }

    /// Rebuilds from parts checked by a decoder: `start` must begin at 0,
    /// never decrease, end at `segs.len()`, and have one entry per pixel + 1.
    pub(crate) fn from_parts(rect: Rect, start: Vec<usize>, segs: Vec<Segment>) -> RegionLists {
        debug_assert_eq!(start.len(), area(&rect) + 1);
        debug_assert_eq!(start.last().copied(), Some(segs.len()));
        RegionLists { rect, start, segs }
    }
}

/// Composited pixels of a region: premultiplied RGBA *without* the
/// background (the background is applied once, on the gathered image).
#[derive(Debug, Clone, PartialEq)]
pub struct RegionPixels {
    /// The region.
    pub rect: Rect,
    /// Row-major pixels of `rect`.
    pub px: Vec<Rgba>,
}

impl RegionPixels {
    /// Whether a pixel is exactly clear (all four channels `+0.0`): what RLE
    /// collapses into runs.
    #[inline]
    pub fn is_clear(p: &Rgba) -> bool {
        p.rgb[0].to_bits() == 0
            && p.rgb[1].to_bits() == 0
            && p.rgb[2].to_bits() == 0
            && p.a.to_bits() == 0
    }
}
