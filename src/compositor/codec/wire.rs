//! Byte-level helpers shared by the codecs: header, little-endian words,
//! validated segments and pixels, and the decode error.

use crate::base::segment::{Rgba, Segment};
use crate::base::Rect;
use crate::compositor::canonical;
use crate::compositor::region::{area, is_valid};

use super::HEADER_BYTES;

/// Why bytes were rejected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// The input ended early.
    #[error("byte {offset}: truncated: need {need} more bytes, {have} left")]
    Truncated {
        /// Where the read started.
        offset: usize,
        /// Bytes needed.
        need: usize,
        /// Bytes left.
        have: usize,
    },
    /// The bytes are not what this codec writes.
    #[error("byte {offset}: {msg}")]
    Malformed {
        /// Where the problem is.
        offset: usize,
        /// What is wrong.
        msg: String,
    },
    /// A size exceeds the receiver's limits.
    #[error("{what} = {value} exceeds the limit {limit}")]
    TooLarge {
        /// Which size.
        what: &'static str,
        /// Its value.
        value: u64,
        /// The limit.
        limit: u64,
    },
}

/// Receiver-side limits on what one message may make it allocate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Largest region, pixels.
    pub max_pixels: u64,
    /// Longest list of one pixel.
    pub max_list: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_pixels: 1 << 22,
            max_list: 1 << 16,
        }
    }
}

/// Appends the header.
pub fn put_header(out: &mut Vec<u8>, kind: u8, codec: u8, r: &Rect) {
    out.extend_from_slice(&[b'P', b'V', kind, codec, 0, 0, 0, 1]);
    for v in [r.x0, r.y0, r.x1, r.y1] {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// Appends a little-endian `u32`.
#[inline]
pub fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// Appends a segment (six `f32`, bit-exact).
#[inline]
pub fn put_segment(out: &mut Vec<u8>, s: &Segment) {
    for v in [
        s.z_front,
        s.z_back,
        s.rgba.rgb[0],
        s.rgba.rgb[1],
        s.rgba.rgb[2],
        s.rgba.a,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// Appends a pixel (four `f32`, bit-exact).
#[inline]
pub fn put_pixel(out: &mut Vec<u8>, p: &Rgba) {
    for v in [p.rgb[0], p.rgb[1], p.rgb[2], p.a] {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// A cursor over untrusted bytes.
pub struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// Reads from the start of `bytes`.
    pub fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes, at: 0 }
    }

    /// Current offset.
    pub fn offset(&self) -> usize {
        self.at
    }

    /// Bytes left.
    pub fn left(&self) -> usize {
        self.bytes.len() - self.at
    }

    /// An error at the current offset.
    pub fn error(&self, msg: impl Into<String>) -> DecodeError {
        DecodeError::Malformed {
            offset: self.at,
            msg: msg.into(),
        }
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        if self.left() < n {
            return Err(DecodeError::Truncated {
                offset: self.at,
                need: n,
                have: self.left(),
            });
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    /// The next `n` bytes (for codecs with byte-level payloads).
    pub fn bytes(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        self.take(n)
    }

    /// The byte at absolute offset `at`, if there is one (no advance).
    pub fn peek_at(&self, at: usize) -> Option<u8> {
        self.bytes.get(at).copied()
    }

    /// Fails unless `n` more bytes are there (checked before allocating).
    pub fn need(&self, n: u64) -> Result<(), DecodeError> {
        if (self.left() as u64) < n {
            return Err(DecodeError::Truncated {
                offset: self.at,
                need: n.min(usize::MAX as u64) as usize,
                have: self.left(),
            });
        }
        Ok(())
    }

    /// A little-endian `u32`.
    pub fn u32(&mut self) -> Result<u32, DecodeError> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn f32s<const N: usize>(&mut self) -> Result<[f32; N], DecodeError> {
        let at = self.at;
        let b = self.take(4 * N)?;
        let mut v = [0.0f32; N];
        for (k, c) in b.chunks_exact(4).enumerate() {
            v[k] = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            if !v[k].is_finite() {
                return Err(DecodeError::Malformed {
                    offset: at + 4 * k,
                    msg: format!("non-finite value {}", v[k]),
                });
            }
        }
        Ok(v)
    }

    /// A segment, checked: finite, `z_front <= z_back`, `0 <= a <= 1`, not clear.
    pub fn segment(&mut self) -> Result<Segment, DecodeError> {
        let at = self.at;
        let [z_front, z_back, r, g, b, a] = self.f32s::<6>()?;
        let s = Segment {
            z_front,
            z_back,
            rgba: Rgba { rgb: [r, g, b], a },
        };
        let bad = |msg: String| DecodeError::Malformed { offset: at, msg };
        if z_front > z_back {
            return Err(bad(format!(
                "segment with z_front {z_front} > z_back {z_back}"
            )));
        }
        if !(0.0..=1.0).contains(&a) {
            return Err(bad(format!("segment alpha {a} outside [0, 1]")));
        }
        if canonical::is_clear(&s) {
            return Err(bad("clear segment (canonical lists hold none)".into()));
        }
        Ok(s)
    }

    /// A pixel, checked: finite, `0 <= a <= 1`.
    pub fn pixel(&mut self) -> Result<Rgba, DecodeError> {
        let at = self.at;
        let [r, g, b, a] = self.f32s::<4>()?;
        if !(0.0..=1.0).contains(&a) {
            return Err(DecodeError::Malformed {
                offset: at + 12,
                msg: format!("pixel alpha {a} outside [0, 1]"),
            });
        }
        Ok(Rgba { rgb: [r, g, b], a })
    }

    /// Reads and checks the header; returns the rectangle.
    pub fn header(&mut self, kind: u8, codec: u8, limits: &Limits) -> Result<Rect, DecodeError> {
        let m = self.take(8)?;
        if m != [b'P', b'V', kind, codec, 0, 0, 0, 1] {
            return Err(DecodeError::Malformed {
                offset: 0,
                msg: format!(
                    "bad magic {m:02x?}: expected kind '{}' codec '{}' version 1",
                    kind as char, codec as char
                ),
            });
        }
        let r = Rect {
            x0: self.u32()?,
            y0: self.u32()?,
            x1: self.u32()?,
            y1: self.u32()?,
        };
        debug_assert_eq!(self.at, HEADER_BYTES);
        if !is_valid(&r) {
            return Err(DecodeError::Malformed {
                offset: 8,
                msg: format!("inverted rectangle {r:?}"),
            });
        }
        let px = area(&r) as u64;
        if px > limits.max_pixels {
            return Err(DecodeError::TooLarge {
                what: "region pixels",
                value: px,
                limit: limits.max_pixels,
            });
        }
        Ok(r)
    }

    /// Fails if bytes are left over.
    pub fn finish(&self) -> Result<(), DecodeError> {
        if self.left() != 0 {
            return Err(self.error(format!("{} trailing bytes", self.left())));
        }
        Ok(())
    }
}

/// Appends one pixel's list: its segment count, then the segments (what
/// [`read_list`] reads back after the count).
pub fn put_list(out: &mut Vec<u8>, list: &[Segment]) {
    put_u32(out, list.len() as u32);
    for s in list {
        put_segment(out, s);
    }
}

/// Reads `count` segments of one pixel onto `segs`, checking canonical order.
pub fn read_list(
    rd: &mut Reader,
    count: u32,
    limits: &Limits,
    segs: &mut Vec<Segment>,
) -> Result<(), DecodeError> {
    if count as u64 > limits.max_list {
        return Err(DecodeError::TooLarge {
            what: "segments in one pixel",
            value: count as u64,
            limit: limits.max_list,
        });
    }
    rd.need(count as u64 * super::SEGMENT_BYTES as u64)?;
    let first = segs.len();
    for _ in 0..count {
        let at = rd.offset();
        let s = rd.segment()?;
        if segs.len() > first
            && canonical::order(&segs[segs.len() - 1], &s) == std::cmp::Ordering::Greater
        {
            return Err(DecodeError::Malformed {
                offset: at,
                msg: "segments of a pixel out of depth order".into(),
            });
        }
        segs.push(s);
    }
    Ok(())
}

/// The high bit of a word marks a run of empty pixels.
pub const RUN: u32 = 0x8000_0000;
