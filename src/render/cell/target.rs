//! Where a scan writes: the tile's segment lists, the integration batch
//! and the scan's counters ([`ScanTarget`], [`ScanCounts`]). Below both scan
//! kernels — the scalar one ([`super::scan`]) and the AVX2 box kernel
//! ([`super::scan_box`]) — so that the two do not import each other.

use super::integrate::{Batch, Integrator, PreparedTf, BATCH, NO_PIECE};
use super::list::{Inserted, SegmentLists};
use super::watch::Extent;
use crate::base::{Rect, Segment};

/// Counters of one scan.
#[derive(Debug, Clone, Copy, Default)]
pub struct ScanCounts {
    /// Pixel centres found inside a tet: in orthographic views the covered
    /// ones (the scalar span scan and the vectorised box scan test
    /// different candidate sets but count alike, so the virtual clock does
    /// not depend on the CPU), in perspective every one tested.
    pub pixels_tested: u64,
    /// Ray segments produced.
    pub segments_generated: u64,
    /// Merge operations by partial composition.
    pub segments_merged: u64,
    /// Pieces the exact integrator cut crossing segments into.
    pub segment_pieces: u64,
}

impl ScanCounts {
    /// Adds another scan's counts.
    pub fn add(&mut self, o: &ScanCounts) {
        self.pixels_tested += o.pixels_tested;
        self.segments_generated += o.segments_generated;
        self.segments_merged += o.segments_merged;
        self.segment_pieces += o.segment_pieces;
    }
}

/// Segments queued for integration and insertion: the integration lanes
/// and each segment's pixel and depths. The caller's, kept from one
/// [`ScanTarget`] to the next: about 6 KB of lanes plus vectors that grow
/// to their size once, which a target per ERT update batch or per node
/// step would otherwise clear and grow anew each time.
#[derive(Debug, Clone)]
pub struct Pending {
    /// The integration lanes (`lanes.n` segments queued).
    pub lanes: Batch,
    /// Each queued segment's local pixel index.
    pub idx: [u32; BATCH],
    /// Its `z_front`.
    pub z_front: [f32; BATCH],
    /// Its `z_back`.
    pub z_back: [f32; BATCH],
    /// How many of them [`ScanTarget::settle`] passed to
    /// [`SegmentLists::may_record`] (kept queued).
    pub passed: usize,
    /// With `Some`: the extent of the segments queued so far, kept while
    /// the ERT scan waits to start its watch ([`Pending::extent`]).
    pub spanned: Option<Extent>,
    /// How many of the queued segments `spanned` holds.
    pub spanned_upto: usize,
}

impl Default for Pending {
    fn default() -> Self {
        Pending {
            lanes: Batch::default(),
            idx: [0; BATCH],
            z_front: [0.0; BATCH],
            z_back: [0.0; BATCH],
            passed: 0,
            spanned: None,
            spanned_upto: 0,
        }
    }
}

impl Pending {
    /// Takes the queued segments into `spanned` (if kept) and returns it:
    /// the extent of the segments queued since it was set.
    pub fn extent(&mut self) -> Option<Extent> {
        let (from, n) = (self.spanned_upto, self.lanes.n);
        let e = self.spanned.as_mut()?;
        e.add(&self.z_back[from..n]);
        self.spanned_upto = n;
        Some(*e)
    }
}

/// Everything a scan needs besides the tet.
pub struct ScanTarget<'a> {
    /// The tile's lists.
    pub lists: &'a mut SegmentLists,
    /// The tile.
    pub tile: Rect,
    /// Transfer function.
    pub tf: &'a PreparedTf,
    /// Integrator.
    pub integrator: Integrator,
    /// Partial composition on insertion.
    pub partial: bool,
    /// Insert with [`crate::base::canonical::insert`] (merge order fixed by the
    /// depths, exact joins) instead of [`super::list::insert_sorted`].
    pub canonical: bool,
    /// Counters.
    pub counts: &'a mut ScanCounts,
    /// Segments waiting to be integrated and inserted: the caller's
    /// buffers, kept from one target to the next (see [`Pending`]).
    pub pending: &'a mut Pending,
    /// Whether the CPU runs the vectorised box scan ([`super::scan_box`]).
    pub simd: bool,
    /// The transfer-function piece of the cell being scanned when its whole
    /// scalar range lies in one piece ([`PreparedTf::single_piece`]), else
    /// `NO_PIECE`: its segments then skip the per-segment piece look-up.
    pub cell_piece: u16,
}

impl<'a> ScanTarget<'a> {
    /// A target writing into `lists` (the lists of `tile`), with partial
    /// composition if `partial`, in canonical form if `canonical`,
    /// queueing in `pending` (where the segments a target left queued at
    /// [`ScanTarget::settle`] wait, and nothing else).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        lists: &'a mut SegmentLists,
        tile: Rect,
        tf: &'a PreparedTf,
        integrator: Integrator,
        partial: bool,
        canonical: bool,
        counts: &'a mut ScanCounts,
        pending: &'a mut Pending,
    ) -> Self {
        debug_assert!(pending.passed <= pending.lanes.n);
        ScanTarget {
            lists,
            tile,
            tf,
            integrator,
            partial,
            canonical,
            counts,
            pending,
            simd: simd_available(),
            cell_piece: NO_PIECE,
        }
    }

    /// Queues the segment of pixel `(i, j)`; integrates and inserts when the batch is full.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn emit(
        &mut self,
        i: u32,
        j: u32,
        z_in: f32,
        z_out: f32,
        s_in: f32,
        s_out: f32,
        length: f32,
    ) {
        let idx = (j - self.tile.y0) * self.tile.width() + (i - self.tile.x0);
        let piece = self.cell_piece;
        self.emit_local(idx, [z_in, z_out, s_in, s_out, length], piece);
    }

    /// Queues the segment `[z_in, z_out, s_in, s_out, length]` of the
    /// tile's pixel `idx` (row-major) in transfer-function piece `piece`
    /// (or `NO_PIECE`); integrates and inserts when the batch is full.
    #[inline(always)]
    pub fn emit_local(&mut self, idx: u32, seg: [f32; 5], piece: u16) {
        let [z_in, z_out, s_in, s_out, length] = seg;
        let p = &mut *self.pending;
        let n = p.lanes.n;
        p.lanes.s_in[n] = s_in;
        p.lanes.s_out[n] = s_out;
        p.lanes.len[n] = length;
        p.lanes.piece_hint[n] = piece;
        p.idx[n] = idx;
        p.z_front[n] = z_in;
        p.z_back[n] = z_out;
        p.lanes.n = n + 1;
        if n + 1 == BATCH {
            self.flush();
        }
    }

    /// At an ERT rebuild point: integrates and inserts the queued segments
    /// unless that cannot record a change for the drain (see
    /// [`SegmentLists::may_record`]), in which case they stay queued for the
    /// next target. Returns whether the lists have changes to drain.
    pub fn settle(&mut self) -> bool {
        let p = &mut *self.pending;
        let n = p.lanes.n;
        let tf = self.tf;
        let may = self.lists.may_record(
            &p.idx[p.passed..n],
            &p.lanes.len[p.passed..n],
            |len| tf.optical_depth_bound(len),
            BATCH,
        );
        p.passed = n;
        if !may {
            return false;
        }
        self.flush();
        true
    }

    /// Integrates the queued segments and inserts them into their lists.
    pub fn flush(&mut self) {
        let p = &mut *self.pending;
        let n = p.lanes.n;
        if n == 0 {
            return;
        }
        if p.passed > 0 {
            self.lists.forget_queued(&p.idx[..p.passed]);
            p.passed = 0;
        }
        p.extent();
        p.spanned_upto = 0;
        self.tf.integrate_batch(self.integrator, &mut p.lanes);
        p.lanes.n = 0;
        self.counts.segments_generated += n as u64;
        self.counts.segment_pieces += p.lanes.pieces as u64;
        if self.partial && !self.canonical {
            let lanes = &p.lanes;
            self.counts.segments_merged +=
                self.lists
                    .insert_partial_run(&p.idx[..n], &p.z_front[..n], &p.z_back[..n], |l| {
                        lanes.result(l)
                    });
            return;
        }
        for l in 0..n {
            let idx = p.idx[l];
            let seg = Segment {
                z_front: p.z_front[l],
                z_back: p.z_back[l],
                rgba: p.lanes.result(l),
            };
            if self.canonical {
                self.counts.segments_merged +=
                    self.lists.insert_canonical(idx as usize, seg, self.partial) as u64;
                continue;
            }
            match self.lists.insert(idx as usize, seg, self.partial) {
                Inserted::New => {}
                Inserted::Merged => self.counts.segments_merged += 1,
                Inserted::MergedBoth => self.counts.segments_merged += 2,
            }
        }
    }
}

/// Whether this CPU can run the AVX2 kernels ([`super::scan_box`],
/// [`super::single_x8`]).
pub fn simd_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
