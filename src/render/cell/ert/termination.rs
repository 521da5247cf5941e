//! The termination depth of one pixel, and the error bound it implies.
//!
//! A pixel's list holds the segments known so far, sorted by `z_front`, with
//! gaps where cells have not been scan-converted yet. Walking it front to back
//! and compositing only the alphas, `A_k = A_{k-1} + (1 - A_{k-1}) a_k`, gives
//! after segment `k` a *lower bound* of the true opacity in front of that
//! segment's `z_back`: the unknown segments in the gaps can only add opacity
//! ("over" never lowers alpha). The first `k` with `A_k >= threshold` makes
//! the pixel terminated; its termination depth is that segment's `z_back`
//! (conservative: the threshold is crossed somewhere inside the segment, and
//! nothing in the list tells where — with partial composition a segment may be
//! a long merged stretch). Everything whose `z_front` is at or behind this depth
//! is attenuated by at least `1 - threshold`.

use crate::base::segment::Segment;

/// Termination depth of a pixel whose list is `list` (sorted by `z_front`):
/// the `z_back` of the first segment at which the alpha accumulated front to
/// back over the listed segments reaches `threshold`; `+inf` if it never does
/// (not terminated).
#[inline]
pub fn termination_depth(list: &[Segment], threshold: f32) -> f32 {
    let mut acc = 0.0f32;
    for s in list {
        acc += (1.0 - acc) * s.rgba.a;
        if acc >= threshold {
            return s.z_back;
        }
    }
    f32::INFINITY
}

/// The largest change ERT can make to one channel of one pixel:
/// `(1 - threshold) * max(max_radiance, background)`.
///
/// Behind the depth `z` where the pixel terminates, the full image adds
/// `T(z) (C_b + (1 - A_b) bg)` and the ERT image the same with fewer segments;
/// both brackets lie in `[0, max(R, bg)]` because a premultiplied colour is at
/// most `R` times its alpha. With `T(z) <= 1 - threshold` the difference is at
/// most `(1 - threshold) max(R, bg)`. On a black background (every scene of the
/// project) this is scene.md's `(1 - threshold) R`. `threshold >= 1` gives 0.
pub fn error_bound(threshold: f64, max_radiance: f64, background: [f64; 3]) -> f64 {
    let bg = background.iter().cloned().fold(0.0, f64::max);
    (1.0 - threshold.min(1.0)).max(0.0) * max_radiance.max(bg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::segment::Rgba;

    fn seg(zf: f32, zb: f32, a: f32) -> Segment {
        Segment {
            z_front: zf,
            z_back: zb,
            rgba: Rgba { rgb: [a; 3], a },
        }
    }

    #[test]
    fn crosses_inside_the_segment_that_reaches_the_threshold() {
        let l = [seg(0.0, 1.0, 0.5), seg(3.0, 4.0, 0.5), seg(5.0, 6.0, 0.8)];
        // 0.5, 0.75, 0.95
        assert_eq!(termination_depth(&l, 0.9), 6.0);
        assert_eq!(termination_depth(&l, 0.75), 4.0);
        assert_eq!(termination_depth(&l, 0.99), f32::INFINITY);
        assert_eq!(termination_depth(&[], 0.5), f32::INFINITY);
    }

    #[test]
    fn bound_is_zero_when_off_and_scales_with_radiance() {
        assert_eq!(error_bound(1.0, 1.0, [0.0; 3]), 0.0);
        assert!((error_bound(0.9, 0.5, [0.0; 3]) - 0.05).abs() < 1e-12);
        assert!((error_bound(0.9, 0.5, [1.0, 0.0, 0.0]) - 0.1).abs() < 1e-12);
    }

    /// The smallest termination depth per pixel over the drains so far.
    fn drain_min(lists: &mut crate::render::cell::list::SegmentLists, depth: &mut [f32], thr: f32) {
        lists.drain_changed(|idx, list| depth[idx] = depth[idx].min(termination_depth(list, thr)));
    }

    proptest::proptest! {
        /// Recording only the changes that can lower a termination depth
        /// (`track_terminations`) gives the ERT scan the same depths, drain
        /// after drain, as recording every change: appends, merges with the
        /// last segment (also a few ulps short of it and zero-length ones),
        /// insertions in front, general insertions, opacity 0 and 1; also
        /// when the watch starts on lists that hold segments already (at
        /// op `start`; the scan drains nothing before).
        #[test]
        fn tracking_terminations_keeps_every_drained_depth(
            thr in proptest::sample::select(vec![0.3f32, 0.9, 0.99]),
            ops in proptest::collection::vec(
                (0u8..5, 0u32..3, 0u8..10, 0u8..3, 0u8..3,
                 proptest::sample::select(vec![0.0f32, 0.2, 0.5, 0.9, 0.995, 1.0])),
                1..60),
            start in proptest::sample::select(vec![0usize, 0, 5, 20, 40]),
        ) {
            use crate::render::cell::list::SegmentLists;
            let (mut all, mut crossing) = (SegmentLists::new(3, 1), SegmentLists::new(3, 1));
            all.track_changes();
            let (mut d_all, mut d_crossing) = ([f32::INFINITY; 3], [f32::INFINITY; 3]);
            let mut run: (Vec<u32>, Vec<f32>, Vec<f32>, Vec<Rgba>) = Default::default();
            for (op, &(kind, px, z, len, jitter, a)) in ops.iter().enumerate() {
                if op == start {
                    crossing.track_terminations(thr);
                }
                let zf = match jitter {
                    0 => z as f32,
                    1 => f32::from_bits((z as f32).to_bits().saturating_sub(1)),
                    _ => f32::from_bits((z as f32).to_bits() + 1),
                };
                let s = seg(zf, zf + len as f32, a);
                match kind {
                    // Queue for a run (the scan's batched insertion).
                    0..=2 => {
                        run.0.push(px);
                        run.1.push(s.z_front);
                        run.2.push(s.z_back);
                        run.3.push(s.rgba);
                    }
                    3 => {
                        all.insert(px as usize, s, true);
                        crossing.insert(px as usize, s, true);
                    }
                    _ => {
                        for l in [&mut all, &mut crossing] {
                            l.insert_partial_run(&run.0, &run.1, &run.2, |k| run.3[k]);
                        }
                        run = Default::default();
                        if op < start {
                            continue;
                        }
                        drain_min(&mut all, &mut d_all, thr);
                        drain_min(&mut crossing, &mut d_crossing, thr);
                        proptest::prop_assert_eq!(d_all.map(f32::to_bits), d_crossing.map(f32::to_bits));
                    }
                }
            }
            proptest::prop_assert_eq!(all.lists(), crossing.lists());
        }

        /// When `cannot_cross` says so, no list has crossed: pixels whose
        /// segments (exact integrator) tile or sparsely fill depth ranges
        /// around the length the threshold needs at the largest
        /// extinction, merged as the scan merges them; transfer functions
        /// of constant opacity (every segment at that extinction: the
        /// bound is tight) or ramps, depths far from 0 (rounding).
        #[test]
        fn cannot_cross_holds(
            thr in proptest::sample::select(vec![0.5f32, 0.9, 0.99, 0.999]),
            opacity in proptest::sample::select(vec![0.3f64, 0.7, 0.95, -1.0]),
            unit in proptest::sample::select(vec![1.0f64, 5.0]),
            z0 in proptest::sample::select(vec![-200.0f32, 0.0, 150.0]),
            factor in 0.5f64..1.3,
            pixels in proptest::collection::vec(
                proptest::collection::vec((0.0f32..1.0, 0.0f32..1.0, 0u8..4), 1..30), 1..4),
        ) {
            use crate::render::cell::integrate::{Integrator, PreparedTf};
            use crate::render::cell::list::SegmentLists;
            use crate::render::cell::watch::{cannot_cross, Extent};
            use crate::scene::transfer::TransferFunction;
            let rows: Vec<[f64; 5]> = if opacity >= 0.0 {
                vec![[0.0, 0.5, 0.5, 0.5, opacity], [1.0, 0.5, 0.5, 0.5, opacity]]
            } else {
                vec![[0.0, 0.2, 0.3, 0.9, 0.0], [0.5, 0.8, 0.3, 0.2, 0.9], [1.0, 0.9, 0.9, 0.1, 0.4]]
            };
            let tf = PreparedTf::new(&TransferFunction::from_rows(&rows, unit));
            let dpl = tf.max_depth_per_length();
            // The range the threshold needs at the largest extinction, scaled.
            let span = (-(1.0 - f64::from(thr)).ln() / f64::from(dpl) * factor) as f32;
            let mut lists = SegmentLists::new(pixels.len() as u32, 1);
            let mut extent = Extent::new(z0);
            let mut steps = 0;
            for (px, cuts) in pixels.iter().enumerate() {
                // Cut points along [z0, z0 + span]; kind 0 leaves a gap.
                let mut at: Vec<f32> = cuts.iter().map(|c| c.0).collect();
                at.sort_by(f32::total_cmp);
                let mut z_prev = z0;
                for (k, &(_, scalar, kind)) in cuts.iter().enumerate() {
                    let z_next = if k + 1 == cuts.len() { z0 + span } else { z0 + span * at[k] };
                    if kind != 0 && z_next > z_prev {
                        let len = z_next - z_prev;
                        let rgba = tf.integrate(Integrator::Exact, scalar, scalar * 0.9, len);
                        let seg = Segment { z_front: z_prev, z_back: z_next, rgba };
                        lists.insert(px, seg, true);
                        extent.add(&[z_next]);
                    }
                    z_prev = z_next;
                }
                steps = steps.max(cuts.len() as u64);
            }
            if cannot_cross(extent, dpl, steps, thr) {
                for (px, list) in lists.lists().iter().enumerate() {
                    let d = termination_depth(list, thr);
                    proptest::prop_assert!(d.is_infinite(), "pixel {px} crossed at {d}: {list:?}");
                }
            }
        }
    }
}
