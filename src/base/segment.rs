//! A ray segment: the light one stretch of a ray gathers, and the "over"
//! operator that composites two of them front to back.
//!
//! Colour is premultiplied by alpha, so compositing is
//! `C = C_f + (1 - A_f) C_b`, `A = A_f + (1 - A_f) A_b` (scene.md), which is
//! associative: `(a over b) over c == a over (b over c)`. That is what makes
//! partial composition (merging touching segments in any order) sound.

/// Premultiplied RGB and alpha of a stretch of ray (no depth).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rgba {
    /// Premultiplied colour.
    pub rgb: [f32; 3],
    /// Opacity in `[0, 1]`.
    pub a: f32,
}

impl Rgba {
    /// Fully transparent.
    pub const CLEAR: Rgba = Rgba {
        rgb: [0.0; 3],
        a: 0.0,
    };

    /// `self` in front of `back`.
    #[inline(always)]
    pub fn over(self, back: Rgba) -> Rgba {
        let t = 1.0 - self.a;
        Rgba {
            rgb: [
                self.rgb[0] + t * back.rgb[0],
                self.rgb[1] + t * back.rgb[1],
                self.rgb[2] + t * back.rgb[2],
            ],
            a: self.a + t * back.a,
        }
    }
}

/// A ray segment: the light of the ray between depths `z_front` and `z_back`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Depth where the stretch starts (nearer the eye).
    pub z_front: f32,
    /// Depth where the stretch ends; `z_back >= z_front`.
    pub z_back: f32,
    /// Its colour and opacity.
    pub rgba: Rgba,
}

impl Segment {
    /// Its six floats' bits (`z_front`, `z_back`, r, g, b, a): what tests
    /// compare when they require the same segment bit for bit.
    pub fn bits(&self) -> [u32; 6] {
        [
            self.z_front.to_bits(),
            self.z_back.to_bits(),
            self.rgba.rgb[0].to_bits(),
            self.rgba.rgb[1].to_bits(),
            self.rgba.rgb[2].to_bits(),
            self.rgba.a.to_bits(),
        ]
    }

    /// `self` in front of `back`, covering both depth ranges (used when they touch).
    #[inline(always)]
    pub fn merged_with(self, back: Segment) -> Segment {
        Segment {
            z_front: self.z_front,
            z_back: back.z_back,
            rgba: self.rgba.over(back.rgba),
        }
    }
}

/// Whether depth `a` (a segment's end) and `b` (the next one's start) are the
/// same point along the ray, within rounding. Segments that share a face of
/// the mesh have bit-identical depths; those that meet across an edge or a
/// vertex differ by a few ulps.
#[inline(always)]
pub fn touches(a: f32, b: f32) -> bool {
    // Shared faces (the common case) give equal depths: no tolerance needed.
    a == b || (a - b).abs() <= 4.0 * f32::EPSILON * (a.abs() + b.abs()) + f32::MIN_POSITIVE
}
