//! The splat list's records: what the ordering writes per drawn voxel and
//! the rasteriser reads.
//!
//! A footprint is a centre, a centre optical depth `tau_k l_k(x_k)`, a
//! colour and a shape (pre-halved conic and bounding half-sizes,
//! [`Conic`]). In a parallel projection every voxel's shape is the same
//! ([`super::footprint`]), so the orthographic list holds
//! [`Splat<()>`](Splat) records of 24 bytes and the frame keeps the one
//! shape; perspective lists hold [`Splat<Conic>`](Splat), 44 bytes. At 23 %
//! fill of 256^3 that is 91 MB instead of 166 MB of fresh memory written
//! and read per frame. [`ShapeOf`] gives either the record's own shape or
//! the frame's.

use super::footprint::Footprint;
use super::raster::SplatShape;

/// A footprint's shape.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Conic {
    /// Pre-halved conic `(q0, q1, q2)`: the exponent is
    /// `q0 dx² + 2 q1 dx dy + q2 dy²`.
    pub q: [f32; 3],
    /// Half-width of the bounding box, pixels.
    pub rx: f32,
    /// Half-height of the bounding box, pixels.
    pub ry: f32,
}

impl Conic {
    /// The shape of footprint `f`.
    pub fn of(f: &Footprint) -> Conic {
        Conic {
            q: f.q,
            rx: f.rx,
            ry: f.ry,
        }
    }
}

/// Where a record's shape lives.
pub trait ShapeOf: Copy + Send + Sync {
    /// The shape of footprint `f` as the record stores it.
    fn store(f: &Footprint) -> Self;
    /// The record's shape, or the frame's `shared` one.
    fn conic<'a>(&'a self, shared: &'a Conic) -> &'a Conic;
}

/// Perspective: each record holds its shape.
impl ShapeOf for Conic {
    #[inline(always)]
    fn store(f: &Footprint) -> Self {
        Conic::of(f)
    }
    #[inline(always)]
    fn conic<'a>(&'a self, _shared: &'a Conic) -> &'a Conic {
        self
    }
}

/// Orthographic: the frame's one shape.
impl ShapeOf for () {
    #[inline(always)]
    fn store(_f: &Footprint) -> Self {}
    #[inline(always)]
    fn conic<'a>(&'a self, shared: &'a Conic) -> &'a Conic {
        shared
    }
}

/// One splat of the list.
#[derive(Debug, Clone, Copy)]
pub struct Splat<S> {
    /// Centre, continuous pixel coordinates.
    pub x: f32,
    /// Centre, vertical (downward).
    pub y: f32,
    /// Optical depth at the centre, `tau_k l_k(x_k)` (negative: a hole).
    pub depth0: f32,
    /// Colour (not premultiplied).
    pub rgb: [f32; 3],
    /// Shape, or `()` when the frame holds it.
    pub shape: S,
}

impl<S> Splat<S> {
    /// True for [`Splat::hole`].
    #[inline(always)]
    pub fn is_hole(&self) -> bool {
        self.depth0 < 0.0
    }
}

impl<S: ShapeOf> Splat<S> {
    /// The record of footprint `f` with centre optical depth `depth0` and
    /// colour `rgb`.
    #[inline(always)]
    pub fn new(f: &Footprint, depth0: f32, rgb: [f32; 3]) -> Self {
        Splat {
            x: f.x,
            y: f.y,
            depth0,
            rgb,
            shape: S::store(f),
        }
    }

    /// A kept voxel whose footprint misses the image (or lies behind the
    /// eye): kept in the list so that the parallel ordering can write
    /// every voxel to its slot, never drawn.
    #[inline(always)]
    pub fn hole() -> Self {
        Splat {
            x: 0.0,
            y: 0.0,
            depth0: -1.0,
            rgb: [0.0; 3],
            shape: S::store(&Footprint {
                x: 0.0,
                y: 0.0,
                q: [0.0; 3],
                l0: 0.0,
                rx: -1.0,
                ry: -1.0,
            }),
        }
    }

    /// Everything the per-pixel kernels read, with the frame's `shared`
    /// shape where the record has none.
    #[inline(always)]
    pub fn full(&self, shared: &Conic) -> SplatShape {
        let c = self.shape.conic(shared);
        SplatShape {
            x: self.x,
            y: self.y,
            q: c.q,
            depth0: self.depth0,
            rgb: self.rgb,
            rx: c.rx,
            ry: c.ry,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The orthographic record is the 24 bytes the module doc counts, and
    /// both kinds give the same full splat.
    #[test]
    fn records_are_compact_and_agree() {
        assert_eq!(std::mem::size_of::<Splat<()>>(), 24);
        assert_eq!(std::mem::size_of::<Splat<Conic>>(), 44);
        let f = Footprint {
            x: 3.5,
            y: -1.25,
            q: [0.2, -0.05, 0.3],
            l0: 1.0,
            rx: 2.5,
            ry: 2.0,
        };
        let a = Splat::<()>::new(&f, 0.4, [1.0, 0.5, 0.25]).full(&Conic::of(&f));
        let b = Splat::<Conic>::new(&f, 0.4, [1.0, 0.5, 0.25]).full(&Conic::default());
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        assert!(Splat::<()>::hole().is_hole() && Splat::<Conic>::hole().is_hole());
        assert!(!Splat::<()>::new(&f, 0.0, [0.0; 3]).is_hole());
    }
}
