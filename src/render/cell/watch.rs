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
//!
//! A watch may start on lists that already hold segments: each pixel's
//! `t` is then the product of `(1 - alpha) q` over its entries (the walk
//! reads the entries as they are, so only its own and the product's
//! rounding count, a step an entry), and the pixels whose `t` is at the
//! limit already are recorded at once ([`TerminationWatch::new`]).
//!
//! Before it starts, [`cannot_cross`] tells when no list can have crossed:
//! in an orthographic view a ray's segments are disjoint stretches of the
//! depth range they came from, so their optical depth is at most the
//! largest extinction times that range's length.

use crate::base::segment::Segment;

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
    /// A watch over the pixels whose lists are `lists`, for ERT threshold
    /// `threshold` (below 1); calls `record(pixel)` for each pixel whose
    /// list may have crossed it already (none of empty lists).
    pub fn new(
        lists: &[Vec<Segment>],
        threshold: f32,
        mut record: impl FnMut(usize),
    ) -> TerminationWatch {
        let clear = 1.0 - threshold;
        let q = (1.0 - MARGIN_STEP / clear).max(0.0);
        let limit = clear + 1e-6;
        let trans = lists
            .iter()
            .enumerate()
            .map(|(i, list)| {
                let t = list.iter().fold(1.0, |t, s| t * ((1.0 - s.rgba.a) * q));
                // NaN compares false: recorded.
                if !(t > limit) {
                    record(i);
                }
                t
            })
            .collect();
        TerminationWatch {
            trans,
            queued: vec![0.0; lists.len()],
            q,
            limit,
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

/// The depth range the segments of a rectangle of pixels have spanned so
/// far (orthographic: a segment's length is its own depth range).
#[derive(Debug, Clone, Copy)]
pub struct Extent {
    /// At most every segment's `z_front` (the nearest vertex depth of the
    /// rectangle's cells).
    pub z_min: f32,
    /// The largest `z_back` taken in.
    pub z_max: f32,
}

impl Extent {
    /// No segment yet, none nearer than `z_min`.
    pub fn new(z_min: f32) -> Extent {
        Extent {
            z_min,
            z_max: f32::NEG_INFINITY,
        }
    }

    /// Takes segments (their `z_back`) in.
    #[inline]
    pub fn add(&mut self, z_back: &[f32]) {
        // Eight lanes at a time, so that the compiler vectorises it
        // (`maxps`). A NaN segment cannot make a list cross (the walk's
        // comparisons fail), so skipping one is safe.
        let mut acc = [self.z_max; 8];
        let mut chunks = z_back.chunks_exact(8);
        for c in &mut chunks {
            for (a, &z) in acc.iter_mut().zip(c) {
                *a = if z > *a { z } else { *a };
            }
        }
        let max = |m: f32, z: f32| if z > m { z } else { m };
        let m = chunks
            .remainder()
            .iter()
            .fold(self.z_max, |m, &z| max(m, z));
        self.z_max = acc.iter().fold(m, |m, &z| max(m, z));
    }
}

/// Whether no pixel's list can reach `threshold` yet: its segments lie in
/// `extent` (orthographic), at most `steps` a pixel, and a world unit
/// holds an optical depth of at most `depth_per_length`
/// ([`crate::render::cell::integrate::PreparedTf::optical_depth_bound`]).
///
/// A pixel's segments are disjoint stretches of `[z_min, z_max]` (up to
/// a few ulps of the depths each), so their optical depths sum to at
/// most `D = depth_per_length (z_max - z_min)` (rounded up), and the
/// product of their `1 - alpha` is at least `e^{-D} (1 - 1e-5)^steps -
/// 1.2e-7 steps` (the integrators' accuracy, tested in
/// `integrate::tests`; Bernoulli for the power). The walk's `1 - alpha`
/// is that less `2.4e-7` a step (see the module doc); above `1 -
/// threshold` no list crosses. Computed in f64.
pub fn cannot_cross(extent: Extent, depth_per_length: f32, steps: u64, threshold: f32) -> bool {
    if extent.z_min > extent.z_max {
        // Nothing emitted yet.
        return true;
    }
    let dpl = f64::from(depth_per_length) * (1.0 + 1e-5);
    let (z0, z1) = (f64::from(extent.z_min), f64::from(extent.z_max));
    let n = steps as f64;
    // Each segment's length is its own f32 depths' difference: the
    // lengths may overlap by a few ulps of the depths a step.
    let slack = n * 4.0 * f64::from(f32::EPSILON) * z0.abs().max(z1.abs());
    let span = z1 - z0 + slack;
    if !span.is_finite() {
        return false;
    }
    let least = (-(span * dpl + 1e-9)).exp() * (1.0 - 1e-5 * n) - n * (1.2e-7 + 2.4e-7);
    least > 1.0 - f64::from(threshold) + 1e-6
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
            let mut w = TerminationWatch::new(&vec![Vec::new(); 4], thr, |_| {});
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
