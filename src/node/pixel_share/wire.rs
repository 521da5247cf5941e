//! The messages of per-pixel level sharing and their byte forms: node →
//! manager [`PixelLevels`], manager → node [`PixelDepths`]; pixel indices
//! as delta-coded LEB128 varints, read by a [`Reader`] that fails instead
//! of panicking.

use super::quant::NOT_REACHED;
use crate::node::table::TableError;

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
