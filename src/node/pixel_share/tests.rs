//! Tests of per-pixel level sharing: depth codes round up, messages
//! round-trip and reject forged bytes, the store's combination and replies.

use proptest::prelude::*;

use super::*;

proptest! {
    #[test]
    fn codes_round_up(z0 in -500.0f32..500.0, span in 0.001f32..2000.0, t in -0.2f32..1.2) {
        let q = DepthQuant::new(z0, z0 + span);
        let z = z0 + t * span;
        let c = q.up(z);
        prop_assert!(q.value(c) >= z, "code {} value {} < {}", c, q.value(c), z);
        if (0.0..=1.0).contains(&t) {
            prop_assert!(c != NOT_REACHED);
            // Tight: one step less would be below z (unless the step is
            // below f32 resolution there and both codes decode alike).
            if c > 0 {
                prop_assert!(q.value(c - 1) < z || q.value(c - 1) == q.value(c));
            }
        }
    }

    #[test]
    fn pixel_levels_round_trip(
        levels in 1u8..6,
        raw in proptest::collection::btree_map(0u32..600, proptest::collection::vec(any::<u16>(), 5), 0..50),
    ) {
        let d = PixelLevels {
            width: 30,
            height: 20,
            levels,
            footprint: [1, 20, 3, 19],
            pixels: raw.into_iter().map(|(p, v)| (p, v[..levels as usize].to_vec())).collect(),
        };
        let b = d.encode();
        prop_assert_eq!(PixelLevels::decode(&b, 30, 20, levels).unwrap(), d);
    }

    #[test]
    fn decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
        let _ = PixelLevels::decode(&bytes, 30, 20, 3);
        let _ = PixelDepths::decode(&bytes, 30, 20);
    }

    /// The store's certified depth is the L-th smallest of the latest
    /// codes of all nodes, whatever the order the shares arrive in, and
    /// every reply sequence brings a node exactly the final certified
    /// values of the pixels that changed.
    #[test]
    fn store_combines_like_the_definition(
        shares in proptest::collection::vec((0usize..3, 0u32..12, proptest::collection::vec(0u16..50, 2)), 1..40),
    ) {
        let mut s = PixelStore::new(4, 3, 2, 3);
        let mut latest = vec![vec![vec![NOT_REACHED; 2]; 3]; 12]; // [pixel][node][level]
        let mut seen = [NOT_REACHED; 12];
        for (k, p, mut codes) in shares {
            codes.sort_unstable(); // a node's levels are nondecreasing
            for (old, new) in latest[p as usize][k].iter_mut().zip(&codes) {
                *old = (*old).min(*new);
            }
            let d = PixelLevels { width: 4, height: 3, levels: 2, footprint: [0, 3, 0, 2], pixels: vec![(p, codes)] };
            s.apply(k, &d).unwrap();
            let (r, _) = s.reply(0);
            for (p, c) in r.pixels {
                prop_assert!(c < seen[p as usize]);
                seen[p as usize] = c;
            }
        }
        for p in 0..12 {
            let mut all: Vec<u16> = latest[p].iter().flatten().copied().collect();
            let want = lth_smallest(&mut all, 2);
            prop_assert_eq!(s.certified()[p], want);
            prop_assert_eq!(seen[p], want);
        }
    }
}

#[test]
fn forged_counts_and_unordered_pixels_are_errors() {
    let d = PixelDepths {
        width: 4,
        height: 4,
        pixels: vec![(3, 7), (9, 1)],
    };
    let mut b = d.encode();
    assert_eq!(PixelDepths::decode(&b, 4, 4).unwrap(), d);
    assert!(PixelDepths::decode(&b, 4, 5).is_err());
    b[9..13].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(PixelDepths::decode(&b, 4, 4).is_err());
    let bad = PixelDepths {
        width: 4,
        height: 4,
        pixels: vec![(3, 7), (3, 1)],
    };
    assert!(PixelDepths::decode(&bad.encode(), 4, 4).is_err());
    let out = PixelDepths {
        width: 4,
        height: 4,
        pixels: vec![(16, 7)],
    };
    assert!(PixelDepths::decode(&out.encode(), 4, 4).is_err());
}

/// A reply carries only the changes under the node's footprint; a node
/// whose footprint grows gets the whole history of the new part.
#[test]
fn replies_follow_the_footprint() {
    let mut s = PixelStore::new(40, 40, 1, 2);
    let share = |fp: [u32; 4], px: &[u32]| PixelLevels {
        width: 40,
        height: 40,
        levels: 1,
        footprint: fp,
        pixels: px.iter().map(|&p| (p, vec![5])).collect(),
    };
    // Node 1 terminates pixels (1, 1) and (35, 35).
    s.apply(1, &share([0, 39, 0, 39], &[41, 35 * 40 + 35]))
        .unwrap();
    // Node 0 covers only the top-left corner.
    s.apply(0, &share([0, 9, 0, 9], &[])).unwrap();
    assert_eq!(s.reply(0).0.pixels, vec![(41, 5)]);
    assert!(s.reply(0).0.pixels.is_empty());
    // Its footprint grows to the whole screen: the rest arrives.
    s.apply(0, &share([0, 39, 0, 39], &[])).unwrap();
    assert_eq!(s.reply(0).0.pixels, vec![(35 * 40 + 35, 5)]);
}

#[test]
fn lth_smallest_counts_units() {
    assert_eq!(lth_smallest(&mut [5, NOT_REACHED, 3], 2), 5);
    assert_eq!(
        lth_smallest(&mut [5, NOT_REACHED, NOT_REACHED], 2),
        NOT_REACHED
    );
    assert_eq!(lth_smallest(&mut [], 1), NOT_REACHED);
}
