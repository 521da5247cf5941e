//! Cells with one pixel centre, scan-converted while they are binned.
//!
//! On a large mesh nearly every projected cell is smaller than a pixel: at
//! 20 M tetrahedra and 512x384, 99.6 % of the cells that hold a pixel
//! centre in their bounding box hold exactly one, and half of those miss
//! it. Binning such a cell as a [`BinEntry`](super::bin::BinEntry), sorting
//! it, and gathering its vertices again in depth order to find that out
//! costs more than the answer. So in orthographic frames the binning pass,
//! which has the cell's vertices in hand, sets the cell up and tests its one
//! pixel at once ([`one_pixel`], eight at a time with AVX2): a hit is binned
//! as its finished ray segment ([`PixelSeg`]), a miss dropped.
//! The scan merges each tile's segments with its other cells by the same
//! `(nearest depth, cell id)` order ([`PixelSeg::order_key`]), so every
//! list receives the same segments in the same order as before and the
//! image is the same bit for bit.
//!
//! Early ray termination tests cells between rebuilds of its table, counted
//! in cells: with it the misses and flat cells are binned too, marked
//! ([`MISSED`], [`FLAT`]; [`OnePixelMode::All`]), so that it rebuilds, tests
//! and skips where it did with every cell binned. Perspective frames count
//! every pixel tested, covered or not, so they bin their cells as before.

use super::integrate::PreparedTf;
use super::scan::ortho_segment;
use super::setup::setup_tet;
use super::single_x8::Lanes;
use super::target::{simd_available, ScanTarget};
use crate::base::Rect;

/// The finished ray segment of a cell with one pixel centre, in its tile's
/// bin (28 bytes).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct PixelSeg {
    /// Order key: [`super::bin::near_key`] of the cell's nearest depth.
    pub key: u32,
    /// Cell index in the mesh.
    pub cell: u32,
    /// The pixel, row-major in its tile.
    pub idx: u16,
    /// Transfer-function piece of the cell's scalar range, or `NO_PIECE`
    /// ([`PreparedTf::single_piece`]).
    pub piece: u16,
    /// Entry and exit depth.
    pub z_in: f32,
    /// Exit depth.
    pub z_out: f32,
    /// Scalar at entry.
    pub s_in: f32,
    /// Scalar at exit.
    pub s_out: f32,
}

const _: () = assert!(std::mem::size_of::<PixelSeg>() == 28);

/// [`PixelSeg::piece`] of a cell that missed its pixel centre, binned only
/// for early ray termination (which counts every cell between rebuilds).
pub const MISSED: u16 = u16::MAX - 1;
/// [`PixelSeg::piece`] of a cell without volume, binned likewise (counted as
/// degenerate where it is not skipped).
pub const FLAT: u16 = u16::MAX - 2;

impl PixelSeg {
    /// Front-to-back order: [`super::bin::order_key`] of its cell.
    #[inline(always)]
    pub fn order_key(&self) -> u64 {
        (self.key as u64) << 32 | self.cell as u64
    }

    /// The cell's pixel range (one pixel, whole image) in tile `rect`, and its
    /// nearest depth (the key's depth, bit for bit), for the ERT tests.
    #[inline(always)]
    pub fn range_near(&self, rect: Rect) -> ([u32; 4], f32) {
        let w = rect.width();
        let (i, j) = (
            rect.x0 + u32::from(self.idx) % w,
            rect.y0 + u32::from(self.idx) / w,
        );
        ([i, i, j, j], super::record::near_of_key(self.key))
    }

    /// `[z_in, z_out, s_in, s_out, length]` as the scan emits it
    /// (orthographic: the length is `z_out - z_in`).
    #[inline(always)]
    pub fn emitted(&self) -> [f32; 5] {
        [
            self.z_in,
            self.z_out,
            self.s_in,
            self.s_out,
            self.z_out - self.z_in,
        ]
    }

    /// Queues this segment (a hit: its piece is no marker) into `target`,
    /// counting its pixel as tested, as the scan of its cell would.
    #[inline(always)]
    pub fn emit(&self, target: &mut ScanTarget) {
        target.counts.pixels_tested += 1;
        target.emit_local(u32::from(self.idx), self.emitted(), self.piece);
    }
}

/// What the binning does with cells that hold one pixel centre.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OnePixelMode {
    /// Bins them as any other cell (the scan sets them up).
    Binned,
    /// Sets them up and bins the hits as segments; misses are dropped.
    Hits,
    /// Sets them up and bins every one as a segment, misses and flat cells
    /// marked ([`MISSED`], [`FLAT`]): early ray termination counts cells.
    All,
}

/// What [`one_pixel`] found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OnePixel {
    /// The cell has no volume in f32 (counted as degenerate).
    Degenerate,
    /// Its pixel centre is not covered.
    Miss,
    /// The pixel's segment (`idx` and `key` still to be filled in).
    Hit(PixelSeg),
}

/// The cell with vertex ids `ids`, screen-space positions `pos` and scalars
/// `s` (orthographic), whose bounding box holds the one pixel centre
/// `(i, j)`: [`setup_tet`] and [`ortho_segment`], as the scan would do them.
#[inline(always)]
pub fn one_pixel(
    ids: [u32; 4],
    pos: &[[f32; 3]; 4],
    s: &[f32; 4],
    (i, j): (u32, u32),
    tf: &PreparedTf,
) -> OnePixel {
    let Some(t) = setup_tet(ids, pos, s) else {
        return OnePixel::Degenerate;
    };
    match ortho_segment(&t, i, j) {
        None => OnePixel::Miss,
        Some((z_in, z_out, s_in, s_out)) => OnePixel::Hit(PixelSeg {
            key: 0,
            cell: 0,
            idx: 0,
            piece: tf.single_piece(t.s_min, t.s_max),
            z_in,
            z_out,
            s_in,
            s_out,
        }),
    }
}

/// One-pixel cells waiting to be set up eight at a time
/// ([`super::single_x8`]) where the CPU has AVX2, one at a time elsewhere.
/// Results come out in the order the cells went in.
pub struct OnePixelQueue {
    lanes: Lanes,
    /// Per lane: the cell, its order key and its pixel.
    meta: [(u32, u32, (u32, u32)); 8],
    simd: bool,
}

impl Default for OnePixelQueue {
    fn default() -> Self {
        OnePixelQueue {
            lanes: Lanes::default(),
            meta: [(0, 0, (0, 0)); 8],
            simd: simd_available(),
        }
    }
}

/// Where [`OnePixelQueue`] hands each cell's result: `(cell, key, pixel, result)`.
pub trait OnePixelSink {
    /// Takes one cell's result.
    fn take(&mut self, cell: u32, key: u32, pixel: (u32, u32), found: OnePixel);
}

impl OnePixelQueue {
    /// Queues the cell `cell` (order key `key`) with vertex ids `ids`,
    /// vertex slot `k`'s position and scalar `vertex(k)`, and the one pixel
    /// centre `pixel`; results go to `sink` (in order, eight at a time with
    /// AVX2). (The vertices are read where they are: gathered into arrays
    /// first, they were stored and reloaded through the stack, which cost
    /// more than the rest of the binning.)
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn push(
        &mut self,
        (cell, key): (u32, u32),
        ids: [u32; 4],
        vertex: impl Fn(usize) -> ([f32; 3], f32),
        pixel: (u32, u32),
        tf: &PreparedTf,
        sink: &mut impl OnePixelSink,
    ) {
        if !self.simd {
            let pos = std::array::from_fn(|k| vertex(k).0);
            let s = std::array::from_fn(|k| vertex(k).1);
            sink.take(cell, key, pixel, one_pixel(ids, &pos, &s, pixel, tf));
            return;
        }
        let l = self.lanes.n;
        let lanes = &mut self.lanes;
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for (k, &id) in ids.iter().enumerate() {
            let (p, s) = vertex(k);
            lanes.pos[k][0][l] = p[0];
            lanes.pos[k][1][l] = p[1];
            lanes.pos[k][2][l] = p[2];
            lanes.ids[k][l] = id;
            lanes.s[k][l] = s;
            // As `setup_tet` folds them.
            lo = lo.min(s);
            hi = hi.max(s);
        }
        lanes.s_min[l] = lo;
        lanes.s_max[l] = hi;
        lanes.x[l] = pixel.0 as f32 + 0.5;
        lanes.y[l] = pixel.1 as f32 + 0.5;
        self.meta[l] = (cell, key, pixel);
        lanes.n = l + 1;
        if l + 1 == 8 {
            self.run(tf, sink);
        }
    }

    /// Runs the cells still queued.
    pub fn finish(&mut self, tf: &PreparedTf, sink: &mut impl OnePixelSink) {
        if self.lanes.n > 0 {
            self.run(tf, sink);
        }
    }

    fn run(&mut self, tf: &PreparedTf, sink: &mut impl OnePixelSink) {
        #[cfg(target_arch = "x86_64")]
        {
            let lanes = &self.lanes;
            // SAFETY: `simd` is set only where the CPU has AVX2.
            let found = unsafe { super::single_x8::one_pixel_x8(lanes) };
            for l in 0..lanes.n {
                let (cell, key, pixel) = self.meta[l];
                let bit = 1u8 << l;
                let result = if found.redo & bit != 0 {
                    let ids = std::array::from_fn(|k| lanes.ids[k][l]);
                    let pos = std::array::from_fn(|k| std::array::from_fn(|c| lanes.pos[k][c][l]));
                    let s = std::array::from_fn(|k| lanes.s[k][l]);
                    one_pixel(ids, &pos, &s, pixel, tf)
                } else if found.degenerate & bit != 0 {
                    OnePixel::Degenerate
                } else if found.hit & bit != 0 {
                    OnePixel::Hit(PixelSeg {
                        key: 0,
                        cell: 0,
                        idx: 0,
                        piece: tf.single_piece(lanes.s_min[l], lanes.s_max[l]),
                        z_in: found.z_in[l],
                        z_out: found.z_out[l],
                        s_in: found.s_in[l],
                        s_out: found.s_out[l],
                    })
                } else {
                    OnePixel::Miss
                };
                sink.take(cell, key, pixel, result);
            }
        }
        self.lanes.n = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::transfer::TransferFunction;
    use proptest::prelude::*;

    /// Collects results in order.
    struct Collect(Vec<(u32, u32, (u32, u32), OnePixel)>);

    impl OnePixelSink for Collect {
        fn take(&mut self, cell: u32, key: u32, pixel: (u32, u32), found: OnePixel) {
            self.0.push((cell, key, pixel, found));
        }
    }

    /// A coordinate drawn from a few values (so that vertices share
    /// coordinates: faces seen exactly edge-on, ties in the vertex order),
    /// pixel centres and edges, or anywhere.
    fn coord() -> impl Strategy<Value = f32> {
        prop_oneof![
            (0u32..4).prop_map(|k| [3.0f32, 3.5, 4.0, 4.25][k as usize]),
            (2i32..6).prop_map(|i| i as f32 + 0.5),
            2.0f32..6.0,
        ]
    }

    fn vertex() -> impl Strategy<Value = [f32; 3]> {
        (
            coord(),
            coord(),
            prop_oneof![(1u32..4).prop_map(|z| z as f32), 0.5f32..9.0],
        )
            .prop_map(|(x, y, z)| [x, y, z])
    }

    /// A cell: four vertices (sometimes a repeated one), scalars, a pixel
    /// near it, and whether two of its ids are equal (one vertex twice).
    fn cell() -> impl Strategy<Value = ([[f32; 3]; 4], [f32; 4], (u32, u32), bool)> {
        (
            [vertex(), vertex(), vertex(), vertex()],
            [0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0],
            (2u32..6, 2u32..6),
            any::<bool>(),
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]
        /// The eight-lane kernel finds what the scalar set-up and test find
        /// for every cell, bit for bit, in order (batches of any length).
        #[test]
        fn queue_equals_scalar(cells in proptest::collection::vec(cell(), 1..30)) {
            let tf = PreparedTf::new(&TransferFunction::from_rows(
                &[[0.0, 1.0, 0.2, 0.1, 0.3], [0.5, 0.3, 0.3, 0.3, 0.0], [1.0, 0.1, 0.4, 1.0, 0.9]],
                5.0,
            ));
            let mut queue = OnePixelQueue::default();
            let mut got = Collect(Vec::new());
            let mut want = Vec::new();
            for (k, (mut p, s, pixel, repeat)) in cells.into_iter().enumerate() {
                let base = 4 * k as u32;
                let mut ids = [base, base + 1, base + 2, base + 3];
                if repeat {
                    p[3] = p[1];
                    ids[3] = ids[1];
                }
                let key = 7 * k as u32;
                queue.push((k as u32, key), ids, |v| (p[v], s[v]), pixel, &tf, &mut got);
                want.push((k as u32, key, pixel, one_pixel(ids, &p, &s, pixel, &tf)));
            }
            queue.finish(&tf, &mut got);
            let bits = |v: &[(u32, u32, (u32, u32), OnePixel)]| -> Vec<String> {
                v.iter()
                    .map(|(c, k, px, f)| match f {
                        OnePixel::Hit(s) => format!(
                            "{c} {k} {px:?} hit {} {:x} {:x} {:x} {:x}",
                            s.piece,
                            s.z_in.to_bits(),
                            s.z_out.to_bits(),
                            s.s_in.to_bits(),
                            s.s_out.to_bits()
                        ),
                        other => format!("{c} {k} {px:?} {other:?}"),
                    })
                    .collect()
            };
            prop_assert_eq!(bits(&got.0), bits(&want));
        }
    }

    #[test]
    fn the_strategy_makes_every_outcome() {
        // Hits, misses and degenerate cells all occur in the property above:
        // a flat cell, a cell covering its pixel, one missing it.
        let tf = PreparedTf::new(&TransferFunction::from_rows(
            &[[0.0, 1.0, 0.2, 0.1, 0.3], [1.0, 0.1, 0.4, 1.0, 0.9]],
            5.0,
        ));
        let s = [0.1, 0.2, 0.3, 0.4];
        let p = [
            [2.0, 2.0, 1.0],
            [6.0, 2.0, 1.0],
            [2.0, 6.0, 1.0],
            [2.0, 2.0, 3.0],
        ];
        let flat = [
            [2.0, 2.0, 1.0],
            [6.0, 2.0, 1.0],
            [2.0, 6.0, 1.0],
            [3.0, 3.0, 1.0],
        ];
        assert!(matches!(
            one_pixel([0, 1, 2, 3], &p, &s, (2, 2), &tf),
            OnePixel::Hit(_)
        ));
        assert_eq!(one_pixel([0, 1, 2, 3], &p, &s, (5, 5), &tf), OnePixel::Miss);
        assert_eq!(
            one_pixel([0, 1, 2, 3], &flat, &s, (2, 2), &tf),
            OnePixel::Degenerate
        );
    }
}
