//! Ordered compositing of layers through the strategies' schedules:
//! random visibility orders, placements, node counts and radix-k factors
//! against the sequential front-to-back composite.

use super::*;
use crate::base::Rect;
use crate::compositor::codec::layer_codec as codec;
use crate::compositor::layer::{composite, Depth};
use crate::compositor::region::{area, screen};
use crate::compositor::strategy::{from_name, RadixK, Strategy};
use proptest::prelude::{any, prop, prop_assert, prop_assert_eq, proptest, Just};
use proptest::strategy::Strategy as _;

/// A layer over a random rectangle of a `w x h` screen with random
/// premultiplied 16-bit pixels (`RGB <= A`).
fn layer(w: u32, h: u32) -> impl proptest::strategy::Strategy<Value = Layer> {
    (0..w, 0..h, 1..=w, 1..=h, any::<u64>()).prop_map(move |(x0, y0, x1, y1, seed)| {
        let rect = Rect {
            x0: x0.min(x1 - 1),
            y0: y0.min(y1 - 1),
            x1,
            y1,
        };
        let mut s = seed | 1;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let px = (0..area(&rect))
            .map(|_| {
                let a = (next() % 65536) as u16;
                let c = |v: u64| (v % (a as u64 + 1)) as u16;
                [c(next()), c(next()), c(next()), a]
            })
            .collect();
        Layer {
            rect,
            ranks: [0, 0],
            depth: Depth::U16,
            px,
        }
    })
}

/// Layers with ranks a random permutation of `0..L`, on random nodes.
fn scene() -> impl proptest::strategy::Strategy<Value = (u32, u32, usize, Vec<(Layer, usize)>)> {
    (1u32..14, 1u32..14, 1usize..10).prop_flat_map(|(w, h, n)| {
        (
            Just(w),
            Just(h),
            Just(n),
            prop::collection::vec((layer(w, h), 0..n, any::<u32>()), 1..12).prop_map(|mut v| {
                // Ranks: the order of the random keys (a permutation).
                let mut idx: Vec<usize> = (0..v.len()).collect();
                idx.sort_by_key(|&i| (v[i].2, i));
                for (rank, &i) in idx.iter().enumerate() {
                    v[i].0.ranks = [rank as u32, rank as u32];
                }
                v.into_iter().map(|(l, node, _)| (l, node)).collect()
            }),
        )
    })
}

fn held(n: usize, layers: &[(Layer, usize)]) -> Vec<Vec<Layer>> {
    let mut h = vec![Vec::new(); n];
    for (l, node) in layers {
        h[*node].push(l.clone());
    }
    h
}

proptest! {
    /// Radix-k (with early merges) and master give the sequential
    /// front-to-back composite of all layers in rank order, within the
    /// roundings the layer format makes: one `1/2` of `1/65535` per merge
    /// (at most `L - 1` along a pixel) plus the gathered piece's own.
    #[test]
    fn radix_k_keeps_the_composite_order((w, h, n, layers) in scene(), k in 2usize..6) {
        let img = screen(w, h);
        let refs: Vec<&Layer> = layers.iter().map(|(l, _)| l).collect();
        let want = composite(&img, &refs).unwrap();
        let c = codec("rle16").unwrap();
        let bound = (layers.len() as f32 + 1.0) * 0.5 / 65535.0 + 1e-5;
        let strategies: Vec<Box<dyn Strategy>> =
            vec![Box::new(RadixK { k }), from_name("master").unwrap()];
        for s in strategies {
            let sch = s.schedule(n, img);
            let (got, rounds) =
                run(&sch, c.as_ref(), held(n, &layers), [0.0; 3], s.merges_early()).unwrap();
            for (i, (g, e)) in got.pixels.iter().zip(&want).enumerate() {
                for ch in 0..4 {
                    prop_assert!(
                        (g[ch] - e[ch]).abs() <= bound,
                        "{} n={n} pixel {i} channel {ch}: {} vs {}", s.label(), g[ch], e[ch]
                    );
                }
            }
            prop_assert_eq!(rounds.len(), sch.rounds.len());
        }
    }
}

/// The opposite order is detectably different: the test above can fail.
#[test]
fn a_reversed_order_is_caught() {
    let r = screen(1, 1);
    let mk = |rank, v: [u16; 4]| Layer {
        rect: r,
        ranks: [rank, rank],
        depth: Depth::U16,
        px: vec![v],
    };
    let front = mk(0, [60000, 0, 0, 60000]);
    let back = mk(1, [0, 60000, 0, 60000]);
    let c = codec("raw16").unwrap();
    let sch = RadixK { k: 2 }.schedule(2, r);
    let (img, _) = run(
        &sch,
        c.as_ref(),
        vec![vec![back.clone()], vec![front.clone()]],
        [0.0; 3],
        true,
    )
    .unwrap();
    let want = composite(&r, &[&front, &back]).unwrap();
    let wrong = composite(&r, &[&mk(0, back.px[0]), &mk(1, front.px[0])]).unwrap();
    assert!((img.pixels[0][0] - want[0][0]).abs() < 1e-4);
    assert!((want[0][0] - wrong[0][0]).abs() > 0.5);
}

/// Early merges cut what later rounds send: with every rank's layers
/// adjacent to its group's, radix-k's second round carries one layer per
/// piece where the unmerged run carries them all.
#[test]
fn early_merges_send_one_layer_per_chain() {
    let img = screen(16, 16);
    let full = |rank: u32| Layer {
        rect: img,
        ranks: [rank, rank],
        depth: Depth::U16,
        px: vec![[100, 100, 100, 1000]; 256],
    };
    // 4 ranks, k = 2: round 0 groups {0,1} and {2,3}; rank r holds ranks
    // 2r and 2r+1, so after round 0 each member holds 4 adjacent ranks.
    let held: Vec<Vec<Layer>> = (0..4u32)
        .map(|r| vec![full(2 * r), full(2 * r + 1)])
        .collect();
    let c = codec("raw16").unwrap();
    let sch = RadixK { k: 2 }.schedule(4, img);
    let (a, merged) = run(&sch, c.as_ref(), held.clone(), [0.0; 3], true).unwrap();
    let (b, plain) = run(&sch, c.as_ref(), held, [0.0; 3], false).unwrap();
    let bytes = |r: &LayerRound| r.messages.iter().map(|m| m.bytes).sum::<u64>();
    assert_eq!(bytes(&merged[0]), bytes(&plain[0]));
    assert!(
        bytes(&merged[1]) * 3 < bytes(&plain[1]) * 2,
        "{} vs {}",
        bytes(&merged[1]),
        bytes(&plain[1])
    );
    assert!(merged[0].merged.iter().all(|&px| px > 0));
    let e = a.error_against(&b);
    assert!(e.max_abs <= 8.0 * 0.5 * 255.0 / 65535.0 + 1e-3, "{e}");
}
