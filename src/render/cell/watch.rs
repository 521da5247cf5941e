//! Which pixels may have terminated: the filter behind
//! [`super::list::SegmentLists::track_terminations`].
//!
//! The ERT scan walks a changed pixel's list for its termination depth
//! ([`super::ert::termination::termination_depth`]): the first segment at
//! which the alpha accumulated front to back reaches the threshold. A list
//! whose whole accumulated alpha stays below the threshold walks to no
//! crossing, an infinite depth, which the scan's drain ignores; such changes
//! need not be recorded, nor the segments that make them inserted before
//! the drain. This watch tells them apart without walking any list.
//!
//! Each pixel keeps `t`, the product of `1 - alpha` over every segment
//! inserted ("over" multiplies the same factors, so merging leaves it
//! unchanged), times a margin factor `q` a segment. The walk's `1 - alpha`
//! over the whole list equals the exact product up to rounding: at most
//! `2.4e-7` a segment (a merge's and the walk's step, each a few half-ulps
//! of 1, absolute; `1 - alpha` itself is exact for `alpha >= 1/2` and
//! within a relative `6e-8` below), and the product's own steps are
//! relative `2e-7` each. With `q = 1 - 5e-7 / (1 - threshold)`, `t >
//! 1 - threshold` after `n` segments (Bernoulli: `q^-n >= 1 + n (1 - q)`)
//! leaves the exact product above `1 - threshold + n 5e-7` less its
//! relative rounding, hence the walk's `1 - alpha` above `1 - threshold`:
//! no crossing. So a change is recorded once `t <= 1 - threshold` (or `t`
//! is NaN). A threshold close to 1 makes `q` small and records changes
//! early: more walking, never a different depth.

/// Per-pixel transmittances and the queued segments' depth bounds of one
/// rectangle of pixels.
#[derive(Debug, Clone, Default)]
pub struct TerminationWatch {
    /// Per pixel: `t` (see the module doc).
    trans: Vec<f32>,
    /// Per pixel: the summed optical-depth bounds of its queued segments
    /// ([`TerminationWatch::may_record`]).
    queued: Vec<f32>,
    /// The margin factor a segment.
    q: f32,
    /// `t` at or below which a change is recorded: `1 - threshold`, and a
    /// millionth for the first segment's rounding.
    limit: f32,
    /// For [`TerminationWatch::may_record`]: the largest count of queued
    /// segments, and what their rounding and margins keep of `t` at least.
    keep: (usize, f32),
}

/// A bound on the rounding a segment adds to a pixel's accumulated
/// `1 - alpha` (see the module doc), with room to spare.
const MARGIN_STEP: f32 = 5e-7;

impl TerminationWatch {
    /// A watch over `pixels` pixels for ERT threshold `threshold` (below 1).
    pub fn new(pixels: usize, threshold: f32) -> TerminationWatch {
        let clear = 1.0 - threshold;
        TerminationWatch {
            trans: vec![1.0; pixels],
            queued: vec![0.0; pixels],
            q: (1.0 - MARGIN_STEP / clear).max(0.0),
            limit: clear + 1e-6,
            keep: (0, 1.0),
        }
    }

    /// After inserting a segment of opacity `alpha` into pixel `i`:
    /// whether to record the change (it may have made the pixel cross the
    /// threshold).
    #[inline(always)]
    pub fn inserted(&mut self, i: usize, alpha: f32) -> bool {
        self.recorder(self.trans.len()).inserted(i, alpha)
    }

    /// [`TerminationWatch::inserted`] for a run of segments into a
    /// rectangle of `pixels` pixels (all of them): the state in locals, so
    /// that the loop keeps it in registers, and the pixel count the
    /// caller's own bound checks already compare with.
    #[inline(always)]
    pub fn recorder(&mut self, pixels: usize) -> Recorder<'_> {
        Recorder {
            trans: &mut self.trans[..pixels],
            q: self.q,
            limit: self.limit,
        }
    }

    /// Whether inserting the queued segments, into pixels `idx[l]` and
    /// `len[l]` world units long, each of optical depth at most
    /// `depth(len[l])` (`1 - alpha >= e^{-depth}`), may record a change; if
    /// not, their insertion can wait past the next drain, which would find
    /// nothing either way. Segments queued before, and passed in the calls
    /// since the last [`TerminationWatch::forget_queued`], are not passed
    /// again; at most `queued_max` are queued before they are inserted.
    ///
    /// After its queued segments a pixel's `t` is at least `t (1 - X) (q
    /// (1 - 2e-5))^m`, with `X` the sum of their depths (`e^{-x} >= 1 -
    /// x`), `m <= queued_max` their count, and `2e-5` a segment for the
    /// rounding: the integrators' `1 - alpha` is within a relative 1e-5 of
    /// `e^{-D}` for the depths below 1 that can pass (tested in
    /// `integrate::tests`), the rest covers the products' steps and this
    /// bound's own arithmetic. Each segment's depth is added to its
    /// pixel's sum once; only the pixels of new segments can have changed
    /// since the last call.
    pub fn may_record(
        &mut self,
        idx: &[u32],
        len: &[f32],
        depth: impl Fn(f32) -> f32,
        queued_max: usize,
    ) -> bool {
        if self.keep.0 != queued_max {
            self.keep = (queued_max, (self.q * (1.0 - 2e-5)).powi(queued_max as i32));
        }
        let floor = self.limit / self.keep.1;
        // Both the same length, so one bound check covers both.
        let trans = &self.trans[..];
        let queued = &mut self.queued[..trans.len()];
        let mut may = false;
        for (&i, &len) in idx.iter().zip(len) {
            let i = i as usize;
            let x = queued[i] + depth(len);
            queued[i] = x;
            // NaN compares false: recorded.
            may |= !(trans[i] * (1.0 - x) > floor);
        }
        may
    }

    /// Forgets the depths [`TerminationWatch::may_record`] summed for the
    /// segments of pixels `idx` (being inserted).
    pub fn forget_queued(&mut self, idx: &[u32]) {
        let queued = &mut self.queued[..];
        for &i in idx {
            queued[i as usize] = 0.0;
        }
    }
}

/// A [`TerminationWatch`] borrowed for a run of insertions.
pub struct Recorder<'a> {
    trans: &'a mut [f32],
    q: f32,
    limit: f32,
}

impl Recorder<'_> {
    /// After inserting a segment of opacity `alpha` into pixel `i`:
    /// whether to record the change.
    #[inline(always)]
    pub fn inserted(&mut self, i: usize, alpha: f32) -> bool {
        let t = &mut self.trans[i];
        *t *= (1.0 - alpha) * self.q;
        // NaN compares false: recorded.
        !(*t > self.limit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::cell::integrate::{Integrator, PreparedTf};
    use crate::scene::transfer::TransferFunction;

    proptest::proptest! {
        /// When `may_record` lets queued segments wait, inserting them
        /// records nothing: pixels with random histories (some near the
        /// threshold), segments integrated by the exact integrator on the
        /// aorta's transfer function, passed to `may_record` in several
        /// calls as the scan does.
        #[test]
        fn waiting_segments_record_nothing(
            thr in proptest::sample::select(vec![0.5f32, 0.9, 0.99, 0.999]),
            history in proptest::collection::vec((0u32..4, 0.0f32..1.0), 0..30),
            queued in proptest::collection::vec((0u32..4, 0.0f32..1.0, 0.0f32..1.0, 0.0f32..3.0), 1..20),
            cut in 0usize..20,
        ) {
            let rows = [
                [0.0, 0.23, 0.30, 0.75, 0.0],
                [0.1, 0.36, 0.46, 0.85, 0.698],
                [0.34, 0.66, 0.75, 0.95, 0.314],
                [1.0, 0.71, 0.02, 0.15, 0.244],
            ];
            let tf = PreparedTf::new(&TransferFunction::from_rows(&rows, 5.0));
            let mut w = TerminationWatch::new(4, thr);
            for &(i, a) in &history {
                w.inserted(i as usize, a);
            }
            let idx: Vec<u32> = queued.iter().map(|q| q.0).collect();
            let len: Vec<f32> = queued.iter().map(|q| q.3).collect();
            let depth = |len: f32| tf.optical_depth_bound(len);
            let cut = cut.min(idx.len());
            let first = w.may_record(&idx[..cut], &len[..cut], depth, 128);
            let may = w.may_record(&idx[cut..], &len[cut..], depth, 128) || first;
            if !may {
                let recorded: Vec<u32> = queued
                    .iter()
                    .filter(|&&(i, sa, sb, len)| {
                        w.inserted(i as usize, tf.integrate(Integrator::Exact, sa, sb, len).a)
                    })
                    .map(|q| q.0)
                    .collect();
                proptest::prop_assert!(recorded.is_empty(), "recorded {recorded:?}");
            }
        }
    }
}
