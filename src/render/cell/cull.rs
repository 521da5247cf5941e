//! The binning pass's cull, with the per-vertex work done once per vertex.
//!
//! On a large mesh most cells are smaller than a pixel (a 20 M-tet mesh at
//! 512x384: 60 % of the cells hold no pixel centre in their bounding box,
//! 99.6 % of the others exactly one), so deciding whether a cell covers a
//! pixel centre is the frame's commonest question. [`cell_record`]
//! answers it from the four vertices' pixel coordinates (a bounding box,
//! four float-to-integer conversions); but a vertex belongs to some 23
//! tetrahedra. [`VertexBounds`] converts each vertex once: its pixel-centre
//! bounds `ceil(x - 1/2)`, `floor(x - 1/2)` (and in `y`) as 16-bit
//! integers, and its side of the image's edges and of the eye plane as
//! bits. A cell's range is then an integer max over its four vertices and
//! its off-screen test an `and` of four bytes.
//!
//! **The same answer as [`cell_record`], bit for bit**: rounding `x - 1/2`,
//! clamping and `ceil`/`floor` are all monotone, so the bound of the
//! box's corner (`ceil(min x - 1/2)`) is the smallest of the vertices'
//! bounds, and "the box lies left of the image" (`max x < 0`) is "every
//! vertex does". The cull categories, their order (empty, behind the eye,
//! off screen, no pixel centre) and the ranges are those of
//! [`cell_record`]; a test checks it on random vertices.
//!
//! [`cell_record`]: super::bin::cell_record

use super::fastmath::{ceil_i, fclamp, floor_i};
use super::project::ProjectedVertices;
use crate::base::Rect;

/// Vertex left of the image (`x < 0`).
const LEFT: u8 = 1;
/// Above it (`y < 0`).
const ABOVE: u8 = 2;
/// Right of it (`x > width`).
const RIGHT: u8 = 4;
/// Below it (`y > height`).
const BELOW: u8 = 8;
/// At or behind the eye plane (`z <= 0`).
const BEHIND: u8 = 16;
/// No pixel position (perspective: at or behind the eye).
const NO_PIXEL: u8 = 32;
/// Off screen when every vertex is off the same edge.
const OFF_SCREEN: u8 = LEFT | ABOVE | RIGHT | BELOW;

/// Why a cell was not kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Culled {
    /// Its scalar interval has zero opacity.
    Empty,
    /// Outside the image or behind the eye.
    Offscreen,
    /// Inside the image, but its bounding box holds no pixel centre.
    NoPixelCentre,
}

/// Each vertex's pixel-centre bounds and sides, for one frame's image.
#[derive(Debug, Clone)]
pub struct VertexBounds {
    /// Per vertex `[-ceil(x - 1/2), floor(x - 1/2), -ceil(y - 1/2),
    /// floor(y - 1/2)]`, each clamped to the image padded by one pixel
    /// (negated lower bounds, so that one lane-wise max combines all four).
    bounds: Vec<[i16; 4]>,
    /// Per vertex its side bits (`LEFT`, ... `NO_PIXEL`).
    sides: Vec<u8>,
    /// The image.
    full: Rect,
}

impl VertexBounds {
    /// The bounds of `pv`'s vertices in its image. `None` when a side of
    /// the image is longer than 32,765 pixels (the bounds would not fit 16
    /// bits); [`cell_record`](super::bin::cell_record) then culls alone.
    pub fn new(pv: &ProjectedVertices) -> Option<VertexBounds> {
        let (w, h) = pv.size;
        if w > 32_765 || h > 32_765 {
            return None;
        }
        let full = Rect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        };
        let (wf, hf) = (w as f32, h as f32);
        let n = pv.pos.len();
        let mut bounds = Vec::with_capacity(n);
        let mut sides = Vec::with_capacity(n);
        for v in 0..n {
            let [x, y] = pv.pixel(v);
            let mut bits = 0u8;
            bits |= BEHIND * u8::from(pv.pos[v][2] <= 0.0);
            if x.is_nan() || y.is_nan() {
                bits |= NO_PIXEL;
                bounds.push([0; 4]);
            } else {
                for (off, bit) in [
                    (x < 0.0, LEFT),
                    (y < 0.0, ABOVE),
                    (x > wf, RIGHT),
                    (y > hf, BELOW),
                ] {
                    bits |= bit * u8::from(off);
                }
                // As `box_pixels` bounds a box: clamped into the image
                // padded by one, so every value is in [-1, side + 1].
                let lim = |v: f32, hi: u32| fclamp(v - 0.5, -1.0, hi as f32 + 1.0);
                bounds.push([
                    -(ceil_i(lim(x, w)) as i16),
                    floor_i(lim(x, w)) as i16,
                    -(ceil_i(lim(y, h)) as i16),
                    floor_i(lim(y, h)) as i16,
                ]);
            }
            sides.push(bits);
        }
        Some(VertexBounds {
            bounds,
            sides,
            full,
        })
    }

    /// Bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.bounds.capacity() * 8 + self.sides.capacity()
    }

    /// The covered pixel range `[i0, i1, j0, j1]` (inclusive) of the cell
    /// with vertex ids `ids`, or why it is culled as off screen or
    /// holding no pixel centre (the caller has tested its opacity).
    #[inline(always)]
    pub fn range(&self, ids: [u32; 4]) -> Result<[u32; 4], Culled> {
        let s = ids.map(|v| self.sides[v as usize]);
        let all = s[0] & s[1] & s[2] & s[3];
        if all & BEHIND != 0 {
            return Err(Culled::Offscreen);
        }
        let full = self.full;
        if (s[0] | s[1] | s[2] | s[3]) & NO_PIXEL != 0 {
            // Straddles the eye plane (perspective): bound by the screen.
            return Ok([0, full.x1 - 1, 0, full.y1 - 1]);
        }
        if all & OFF_SCREEN != 0 {
            return Err(Culled::Offscreen);
        }
        let b = ids.map(|v| self.bounds[v as usize]);
        let m: [i16; 4] = std::array::from_fn(|k| b[0][k].max(b[1][k]).max(b[2][k].max(b[3][k])));
        let i0 = i32::from(-m[0]).max(0);
        let i1 = i32::from(m[1]).min(full.x1 as i32 - 1);
        let j0 = i32::from(-m[2]).max(0);
        let j1 = i32::from(m[3]).min(full.y1 as i32 - 1);
        if i0 > i1 || j0 > j1 {
            return Err(Culled::NoPixelCentre);
        }
        Ok([i0 as u32, i1 as u32, j0 as u32, j1 as u32])
    }
}
