//! The band's accumulation buffer, channel planes (structure of arrays).
//!
//! A band of `rows x w` premultiplied RGBA pixels is held as four planes
//! (`R`, `G`, `B`, `A`), each row padded by [`LANES`] floats. A run of a
//! splat's alphas is then composited [`LANES`] pixels at a time: one load
//! of eight `A`s, one multiply-add per channel plane, one store each,
//! instead of one four-channel pixel at a time (`rows x w` pixels in
//! interleaved RGBA would need a shuffle per pixel to broadcast `A`). Lanes
//! past the run carry alpha 0, which leaves a pixel bit-for-bit as it is
//! (`p + c 0 = p` and `0 c + 1 p = p` for the non-negative values held
//! here); the row padding keeps those lanes inside the band.

/// Pixels composited at once (one AVX vector, two SSE vectors).
pub const LANES: usize = 8;

/// `p[at .. at + LANES]` as an array.
#[inline(always)]
fn lane(p: &mut [f32], at: usize) -> &mut [f32; LANES] {
    (&mut p[at..at + LANES]).try_into().expect("LANES")
}

/// Four channel planes of one band.
#[derive(Debug, Clone)]
pub struct BandBuf {
    /// Pixels per row.
    w: usize,
    /// Rows.
    rows: usize,
    /// Floats per plane row, `w + LANES`.
    stride: usize,
    /// `R`, `G`, `B`, `A` planes, one after the other.
    data: Vec<f32>,
}

/// Eight consecutive pixels of a row: their `R`, `G`, `B`, `A` lanes.
pub type Lanes<'a> = [&'a mut [f32; LANES]; 4];

impl BandBuf {
    /// A transparent band (`(0, 0, 0, 0)` everywhere).
    pub fn new(w: usize, rows: usize) -> BandBuf {
        let stride = w + LANES;
        BandBuf {
            w,
            rows,
            stride,
            data: vec![0.0; 4 * rows * stride],
        }
    }

    /// Pixels per row.
    #[inline(always)]
    pub fn width(&self) -> usize {
        self.w
    }

    /// Rows.
    #[inline(always)]
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The [`LANES`] pixels `i .. i + LANES` of row `r` (`i < w`; lanes
    /// past the row's end are padding).
    #[inline(always)]
    pub fn lanes(&mut self, r: usize, i: usize) -> Lanes<'_> {
        let plane = self.rows * self.stride;
        let at = r * self.stride + i;
        let (rp, rest) = self.data.split_at_mut(plane);
        let (gp, rest) = rest.split_at_mut(plane);
        let (bp, ap) = rest.split_at_mut(plane);
        [lane(rp, at), lane(gp, at), lane(bp, at), lane(ap, at)]
    }

    /// `A` of row `r`, the `w` pixels.
    #[inline(always)]
    pub fn alpha_row(&self, r: usize) -> &[f32] {
        let at = 3 * self.rows * self.stride + r * self.stride;
        &self.data[at..at + self.w]
    }

    /// Pixel `(i, r)` as premultiplied RGBA.
    pub fn pixel(&self, r: usize, i: usize) -> [f32; 4] {
        let plane = self.rows * self.stride;
        std::array::from_fn(|c| self.data[c * plane + r * self.stride + i])
    }

    /// Writes the band, row by row, into interleaved RGBA `out`
    /// (`rows x w` pixels).
    pub fn write_rgba(&self, out: &mut [[f32; 4]]) {
        for (r, row) in out.chunks_exact_mut(self.w).enumerate().take(self.rows) {
            for (i, px) in row.iter_mut().enumerate() {
                *px = self.pixel(r, i);
            }
        }
    }
}
