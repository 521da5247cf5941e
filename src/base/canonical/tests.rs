//! The canonical form's promise: the composite of a pixel depends only on
//! the set of its segments, however they are spread, inserted and merged.

use proptest::prelude::*;

use super::*;

fn seg(zf: f32, zb: f32, a: f32, c: f32) -> Segment {
    Segment {
        z_front: zf,
        z_back: zb,
        rgba: Rgba {
            rgb: [a * c, a * (1.0 - c), a * 0.5],
            a,
        },
    }
}

fn bits(c: Rgba) -> [u32; 4] {
    [
        c.rgb[0].to_bits(),
        c.rgb[1].to_bits(),
        c.rgb[2].to_bits(),
        c.a.to_bits(),
    ]
}

/// A pixel's segments: a few chains of joined segments separated by gaps,
/// with alphas spread over many orders of magnitude (so rounding differs).
fn pixel() -> impl Strategy<Value = Vec<Segment>> {
    prop::collection::vec(
        (
            1usize..12,
            0.0f32..2.0,
            prop::collection::vec((0.01f32..1.0, 1e-4f32..0.9, 0.0f32..1.0), 12),
        ),
        1..5,
    )
    .prop_map(|chains| {
        let mut out = Vec::new();
        let mut z = 1.0f32;
        for (len, gap, vals) in chains {
            z += gap;
            for &(dz, a, c) in vals.iter().take(len) {
                out.push(seg(z, z + dz, a, c));
                z += dz;
            }
        }
        out
    })
}

fn build(segs: &[Segment], order: &[usize], partial: bool) -> Vec<Segment> {
    let mut l = Vec::new();
    for &k in order {
        insert(&mut l, segs[k], partial);
    }
    l
}

proptest! {
    #[test]
    fn composite_is_independent_of_distribution(
        segs in pixel(),
        owner_seed in prop::collection::vec(0usize..8, 64),
        nodes in 1usize..6,
        perm_seed in prop::collection::vec(any::<u32>(), 64),
    ) {
        let all: Vec<usize> = (0..segs.len()).collect();
        let want = composite(&build(&segs, &all, false));
        let seq = build(&segs, &all, true);
        prop_assert_eq!(bits(composite(&seq)), bits(want));
        // Spread over nodes, each inserting in a shuffled order.
        let mut per_node: Vec<Vec<usize>> = vec![Vec::new(); nodes];
        for k in 0..segs.len() {
            per_node[owner_seed[k] % nodes].push(k);
        }
        let mut lists: Vec<Vec<Segment>> = per_node
            .iter_mut()
            .map(|ks| {
                ks.sort_by_key(|&k| perm_seed[k]);
                build(&segs, ks, true)
            })
            .collect();
        // Merge pairwise in a data-dependent order.
        let mut out = Vec::new();
        while lists.len() > 1 {
            let i = perm_seed[lists.len()] as usize % lists.len();
            let a = lists.swap_remove(i);
            let b = lists.pop().unwrap();
            merge(&a, &b, true, &mut out);
            lists.push(out.clone());
        }
        prop_assert_eq!(bits(composite(&lists[0])), bits(want));
        // Merging never stores more entries than the segments.
        prop_assert!(lists[0].len() <= segs.len());
        // The merged list is the sequential one, entry for entry.
        prop_assert_eq!(&lists[0], &seq);
    }
}

#[test]
fn one_chain_collapses_when_its_ends_are_known_keys() {
    // A chain inserted front to back: fewer pieces than segments.
    let mut l = Vec::new();
    let mut z = 1.0f32;
    for k in 0..64 {
        insert(
            &mut l,
            seg(z, z + 0.01, 0.05 + 0.01 * (k % 7) as f32, 0.3),
            true,
        );
        z += 0.01;
    }
    assert!(l.len() < 16, "{} pieces for 64 segments", l.len());
    assert!(l.windows(2).all(|w| joins(&w[0], &w[1])));
}

#[test]
fn clear_segments_are_dropped_and_order_is_total() {
    let mut l = Vec::new();
    assert_eq!(insert(&mut l, seg(1.0, 2.0, 0.0, 0.0), true), 0);
    assert!(l.is_empty());
    let a = seg(1.0, 2.0, 0.5, 0.1);
    let b = seg(1.0, 2.0, 0.5, 0.2);
    assert_ne!(order(&a, &b), Ordering::Equal);
}

#[test]
fn tree_evaluation_matches_recursive_definition() {
    fn rec(run: &[Segment], keys: &[u32]) -> Segment {
        if run.len() == 1 {
            return run[0];
        }
        let m = *keys.iter().min().unwrap();
        let i = keys.iter().position(|&k| k == m).unwrap();
        rec(&run[..=i], &keys[..i]).merged_with(rec(&run[i + 1..], &keys[i + 1..]))
    }
    let run: Vec<Segment> = (0..9)
        .map(|k| seg(k as f32, k as f32 + 1.0, 0.1 * (k + 1) as f32 / 1.3, 0.4))
        .collect();
    for keys in [
        [5, 3, 5, 3, 9, 1, 1, 7],
        [1, 1, 1, 1, 1, 1, 1, 1],
        [8, 7, 6, 5, 4, 3, 2, 1],
    ] {
        assert_eq!(evaluate(&run, &keys), rec(&run, &keys));
    }
}
