//! Properties of compositing and partial composition in the cell-projection
//! renderer: `over` is associative, merging touching segments in any
//! insertion order gives the same pixel, merged alpha is monotonic and
//! bounded, the batched integrator matches the scalar one, and partial
//! composition changes a real image by less than 1/255.

mod common;

use proptest::prelude::*;

use common::*;
use pvrsim::base::{Rgba, Segment};
use pvrsim::render::cell::integrate::{Batch, BATCH};
use pvrsim::render::cell::list::{composite, insert_sorted, Inserted};
use pvrsim::render::cell::{self, CellOptions, Integrator, PreparedTf};
use pvrsim::scene::TransferFunction;

/// A premultiplied colour: `a` in [0, 1], each `rgb <= a`.
fn rgba() -> impl Strategy<Value = Rgba> {
    // Alpha 0 and 1 exactly are edge cases worth hitting often.
    let alpha = prop_oneof![1 => Just(0.0f32), 1 => Just(1.0f32), 8 => 0.0f32..=1.0];
    (alpha, [0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0]).prop_map(|(a, c)| Rgba {
        rgb: c.map(|c| c * a),
        a,
    })
}

fn close(x: Rgba, y: Rgba, tol: f32) -> bool {
    (x.a - y.a).abs() <= tol && (0..3).all(|c| (x.rgb[c] - y.rgb[c]).abs() <= tol)
}

fn valid(x: Rgba) -> bool {
    (0.0..=1.0).contains(&x.a)
        && x.rgb
            .iter()
            .all(|&c| c.is_finite() && c >= 0.0 && c <= x.a + 1e-6)
}

/// A ray cut into segments: depths (ascending), colours, and for each cut
/// between consecutive segments whether they touch (same depth) or leave a gap.
#[derive(Debug, Clone)]
struct Ray {
    segs: Vec<Segment>,
    /// Number of maximal runs of touching segments.
    runs: usize,
}

fn ray(max_k: usize) -> impl Strategy<Value = Ray> {
    (1..=max_k)
        .prop_flat_map(|k| {
            (
                0.0f32..100.0,
                prop::collection::vec(
                    (
                        0.01f32..10.0,
                        rgba(),
                        prop::bool::weighted(0.25),
                        0.01f32..5.0,
                    ),
                    k,
                ),
            )
        })
        .prop_map(|(start, parts)| {
            let mut z = start;
            let mut segs = Vec::with_capacity(parts.len());
            let mut runs = 1;
            for (i, (len, c, gap, gap_len)) in parts.into_iter().enumerate() {
                if gap && i > 0 {
                    z += gap_len;
                    runs += 1;
                }
                let z_back = z + len;
                segs.push(Segment {
                    z_front: z,
                    z_back,
                    rgba: c,
                });
                z = z_back;
            }
            Ray { segs, runs }
        })
}

fn check_sorted_disjoint(list: &[Segment]) -> Result<(), TestCaseError> {
    for w in list.windows(2) {
        prop_assert!(w[0].z_front <= w[1].z_front, "not sorted: {:?}", list);
        prop_assert!(w[0].z_back <= w[1].z_front, "overlap: {:?}", list);
    }
    for s in list {
        prop_assert!(s.z_front <= s.z_back, "inverted segment {:?}", s);
        prop_assert!(valid(s.rgba), "invalid colour {:?}", s);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, failure_persistence: None, ..ProptestConfig::default() })]

    // 9. `over` is associative.
    #[test]
    fn over_is_associative(a in rgba(), b in rgba(), c in rgba()) {
        let left = a.over(b).over(c);
        let right = a.over(b.over(c));
        prop_assert!(close(left, right, 1e-6), "(a over b) over c = {left:?}, a over (b over c) = {right:?}");
    }

    // 12. A merged segment's alpha is at least each part's and never above 1;
    // its colour stays premultiplied.
    #[test]
    fn merged_alpha_is_monotonic_and_bounded(a in rgba(), b in rgba()) {
        let m = a.over(b);
        prop_assert!(m.a >= a.a && m.a >= b.a, "{a:?} over {b:?} = {m:?}");
        prop_assert!(m.a <= 1.0, "{m:?}");
        prop_assert!(valid(m), "{m:?}");
        // The same through the list: two touching segments merged on insertion.
        let (f, k) = (Segment { z_front: 1.0, z_back: 2.0, rgba: a }, Segment { z_front: 2.0, z_back: 3.5, rgba: b });
        for order in [[f, k], [k, f]] {
            let mut list = Vec::new();
            insert_sorted(&mut list, order[0], true);
            prop_assert_eq!(insert_sorted(&mut list, order[1], true), Inserted::Merged);
            prop_assert_eq!(list.len(), 1);
            prop_assert_eq!((list[0].z_front, list[0].z_back), (1.0, 3.5));
            prop_assert!(list[0].rgba.a >= a.a && list[0].rgba.a >= b.a && list[0].rgba.a <= 1.0, "{:?}", list[0]);
        }
    }

    // 12 (chains). Merging a whole run front to back: alpha never drops, never exceeds 1.
    #[test]
    fn merged_chain_alpha_is_monotonic(r in ray(16)) {
        let mut acc = Rgba::CLEAR;
        for s in &r.segs {
            let next = acc.over(s.rgba);
            prop_assert!(next.a >= acc.a && next.a >= s.rgba.a && next.a <= 1.0, "{acc:?} over {:?} = {next:?}", s.rgba);
            acc = next;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, failure_persistence: None, ..ProptestConfig::default() })]

    // 10. Partial composition does not depend on the insertion order.
    #[test]
    fn partial_composition_is_insertion_order_independent(
        r in ray(12),
        perm_seed in any::<u64>(),
    ) {
        let k = r.segs.len();
        // A permutation from the seed (Fisher-Yates with a small LCG).
        let mut order: Vec<usize> = (0..k).collect();
        let mut x = perm_seed | 1;
        for i in (1..k).rev() {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            order.swap(i, (x >> 33) as usize % (i + 1));
        }
        let want = composite(&r.segs);

        let mut sorted = Vec::new();
        for s in &r.segs {
            insert_sorted(&mut sorted, *s, true);
            check_sorted_disjoint(&sorted)?;
        }
        let mut shuffled = Vec::new();
        for &i in &order {
            insert_sorted(&mut shuffled, r.segs[i], true);
            check_sorted_disjoint(&shuffled)?;
        }
        let (a, b) = (composite(&sorted), composite(&shuffled));
        prop_assert!(close(a, want, 1e-5), "in depth order {a:?}, unmerged {want:?}");
        prop_assert!(close(b, want, 1e-5), "order {order:?}: {b:?}, unmerged {want:?}");
        // Every run of touching segments ends up as one.
        prop_assert_eq!(sorted.len(), r.runs);
        prop_assert_eq!(shuffled.len(), r.runs, "order {:?}: {:?}", order, shuffled);
        prop_assert_eq!(shuffled.first().map(|s| s.z_front), r.segs.first().map(|s| s.z_front));
        prop_assert_eq!(shuffled.last().map(|s| s.z_back), r.segs.last().map(|s| s.z_back));

        // Without partial composition every segment is kept, sorted.
        let mut plain = Vec::new();
        for &i in &order {
            prop_assert_eq!(insert_sorted(&mut plain, r.segs[i], false), Inserted::New);
            check_sorted_disjoint(&plain)?;
        }
        prop_assert_eq!(plain.len(), k);
        prop_assert_eq!(&plain, &r.segs);
    }
}

/// A transfer function with kinks, a flat zero-opacity stretch and an opacity-1 point.
fn test_tf() -> TransferFunction {
    let pts = [
        [0.0, 0.2, 0.3, 0.8, 0.0],
        [0.1, 0.2, 0.3, 0.8, 0.0],
        [0.25, 0.3, 0.8, 0.4, 0.45],
        [0.5, 0.9, 0.9, 0.2, 0.05],
        [0.7, 0.9, 0.3, 0.1, 1.0],
        [0.85, 0.7, 0.0, 0.1, 0.3],
        [1.0, 1.0, 1.0, 1.0, 0.6],
    ];
    TransferFunction::from_rows(&pts, 2.5)
}

fn lane() -> impl Strategy<Value = (f32, f32, f32)> {
    let s = prop_oneof![4 => -0.1f32..1.1, 1 => prop::sample::select(vec![0.0f32, 0.1, 0.25, 0.5, 0.7, 0.85, 1.0])];
    let near = (s.clone(), -0.02f32..0.02).prop_map(|(a, d): (f32, f32)| (a, a + d));
    let pair = prop_oneof![2 => (s.clone(), s), 1 => near];
    let len =
        prop_oneof![1 => Just(0.0f32), 1 => 0.0f32..1e-3, 6 => 0.0f32..5.0, 2 => 5.0f32..60.0];
    (pair, len).prop_map(|((a, b), l)| (a, b, l))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, failure_persistence: None, ..ProptestConfig::default() })]

    // 13. `integrate_batch` matches `integrate` lane by lane, both integrators.
    #[test]
    fn batch_matches_scalar_integration(lanes in prop::collection::vec(lane(), 1..=BATCH)) {
        let tf = PreparedTf::new(&test_tf());
        for integ in INTEGRATORS {
            let mut b = Batch::default();
            b.n = lanes.len();
            for (l, &(s_in, s_out, len)) in lanes.iter().enumerate() {
                b.s_in[l] = s_in;
                b.s_out[l] = s_out;
                b.len[l] = len;
            }
            tf.integrate_batch(integ, &mut b);
            for (l, &(s_in, s_out, len)) in lanes.iter().enumerate() {
                let got = b.result(l);
                let want = tf.integrate(integ, s_in, s_out, len);
                prop_assert!(valid(want), "{integ} scalar ({s_in}, {s_out}, {len}) = {want:?}");
                prop_assert!(close(got, want, 1e-6), "{integ} lane {l} ({s_in}, {s_out}, {len}): batch {got:?}, scalar {want:?}");
            }
        }
    }
}

// 11. Partial composition changes no pixel of the demo image by more than 1/255.
#[test]
fn partial_composition_changes_the_demo_image_by_under_1_255() {
    let input = demo_input();
    for integ in [Integrator::Exact, Integrator::Midpoint] {
        for order in ORDERS {
            let on = CellOptions {
                partial_composition: true,
                ..opts(integ, order)
            };
            let off = CellOptions {
                partial_composition: false,
                ..on
            };
            let (a, sa) = cell::render(input, &on);
            let (b, sb) = cell::render(input, &off);
            assert!(!a.has_non_finite() && !b.has_non_finite());
            assert!(sa.segments_merged > 0 && sb.segments_merged == 0);
            assert_eq!(sa.segments_generated, sb.segments_generated);
            assert!(sa.segments_stored < sb.segments_stored);
            let e = a.error_against_rgba(&b);
            let ((i, j), diff) = (e.worst_pixel, e.max_abs / 255.0);
            eprintln!(
                "{integ} {order}: partial composition on vs off, max abs difference {diff:.3e} ({:.4}/255) at pixel {:?}; segments stored {} vs {}",
                e.max_abs,
                e.worst_pixel,
                sa.segments_stored,
                sb.segments_stored
            );
            assert!(
                diff <= 1.0 / 255.0,
                "{integ} {order}: pixel {:?} {:?} vs {:?}",
                e.worst_pixel,
                a.get(i, j),
                b.get(i, j)
            );
        }
    }
}
