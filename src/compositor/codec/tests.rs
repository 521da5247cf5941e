//! Round trips on random sparse regions and fuzzed bytes.

use proptest::prelude::*;

use super::*;
use crate::base::segment::{Rgba, Segment};
use crate::base::Rect;
use crate::compositor::canonical;

fn region() -> impl Strategy<Value = (RegionLists, bool)> {
    (1u32..9, 1u32..9, 0u32..50, 0u32..50, any::<bool>()).prop_flat_map(|(w, h, x0, y0, partial)| {
        let n = (w * h) as usize;
        prop::collection::vec(
            prop_oneof![
                3 => Just(Vec::new()),
                1 => prop::collection::vec((0.0f32..10.0, 0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0), 1..6),
            ],
            n,
        )
        .prop_map(move |raw| {
            let rect = Rect { x0, y0, x1: x0 + w, y1: y0 + h };
            let lists: Vec<Vec<Segment>> = raw
                .into_iter()
                .map(|l| {
                    l.into_iter()
                        .map(|(z, dz, a, c)| Segment {
                            z_front: (z * 8.0).round() / 8.0,
                            z_back: (z * 8.0).round() / 8.0 + (dz * 4.0).round() / 8.0,
                            rgba: Rgba { rgb: [a * c, a, 0.5 * a], a },
                        })
                        .collect()
                })
                .collect();
            (RegionLists::canonical(rect, &lists, partial), partial)
        })
    })
}

fn codecs() -> Vec<Box<dyn Codec>> {
    list().iter().map(|(n, _)| from_name(n).unwrap()).collect()
}

proptest! {
    #[test]
    fn lists_round_trip((lists, _partial) in region()) {
        for c in codecs() {
            let mut bytes = Vec::new();
            c.encode_lists(&lists, &mut bytes);
            let back = c.decode_lists(&bytes, &Limits::default()).unwrap();
            prop_assert_eq!(&back, &lists);
            let px = lists.composite();
            let mut pb = Vec::new();
            c.encode_pixels(&px, &mut pb);
            prop_assert_eq!(c.decode_pixels(&pb, &Limits::default()).unwrap(), px);
            if c.name() == "raw" {
                prop_assert_eq!(bytes.len() as u64, raw_lists_bytes(&lists));
                prop_assert_eq!(pb.len() as u64, raw_pixels_bytes(&lists.composite()));
            }
        }
    }

    #[test]
    fn random_bytes_never_panic(mut bytes in prop::collection::vec(any::<u8>(), 0..400), kind in 0usize..4) {
        // Half the time, give it a valid header so the body gets fuzzed.
        if kind < 2 && bytes.len() >= 24 {
            bytes[..8].copy_from_slice(&[b'P', b'V', b'L', if kind == 0 { b'r' } else { b'R' }, 0, 0, 0, 1]);
            bytes[8..24].copy_from_slice(&[0, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0, 0, 2, 0, 0, 0]);
        }
        for c in codecs() {
            let _ = c.decode_lists(&bytes, &Limits::default());
            let _ = c.decode_pixels(&bytes, &Limits::default());
        }
    }

    #[test]
    fn mutated_messages_never_panic((lists, _p) in region(), at in any::<prop::sample::Index>(), val in any::<u8>(), cut in any::<prop::sample::Index>()) {
        for c in codecs() {
            let mut bytes = Vec::new();
            c.encode_lists(&lists, &mut bytes);
            let i = at.index(bytes.len());
            bytes[i] = val;
            let _ = c.decode_lists(&bytes, &Limits::default());
            let _ = c.decode_lists(&bytes[..cut.index(bytes.len())], &Limits::default());
        }
    }
}

#[test]
fn errors_name_the_problem() {
    let rect = Rect {
        x0: 0,
        y0: 0,
        x1: 2,
        y1: 1,
    };
    let s = |zf: f32, zb: f32, a: f32| Segment {
        z_front: zf,
        z_back: zb,
        rgba: Rgba { rgb: [a; 3], a },
    };
    let lists = RegionLists::canonical(
        rect,
        &[vec![s(1.0, 2.0, 0.5), s(3.0, 4.0, 0.5)], vec![]],
        true,
    );
    let mut bytes = Vec::new();
    Raw.encode_lists(&lists, &mut bytes);
    let lim = Limits::default();
    // Swap the two segments: out of order.
    let mut b = bytes.clone();
    let (p, q) = (28, 28 + SEGMENT_BYTES);
    let first: Vec<u8> = b[p..q].to_vec();
    b.copy_within(q..q + SEGMENT_BYTES, p);
    b[q..q + SEGMENT_BYTES].copy_from_slice(&first);
    assert!(Raw
        .decode_lists(&b, &lim)
        .unwrap_err()
        .to_string()
        .contains("depth order"));
    // NaN depth.
    let mut b = bytes.clone();
    b[28..32].copy_from_slice(&f32::NAN.to_le_bytes());
    assert!(Raw
        .decode_lists(&b, &lim)
        .unwrap_err()
        .to_string()
        .contains("non-finite"));
    // Inverted depths.
    let mut b = bytes.clone();
    b[28..32].copy_from_slice(&9.0f32.to_le_bytes());
    assert!(Raw
        .decode_lists(&b, &lim)
        .unwrap_err()
        .to_string()
        .contains("z_front"));
    // Truncated, trailing, wrong codec, huge region.
    assert!(matches!(
        Raw.decode_lists(&bytes[..bytes.len() - 1], &lim),
        Err(DecodeError::Truncated { .. })
    ));
    let mut b = bytes.clone();
    b.push(0);
    assert!(Raw
        .decode_lists(&b, &lim)
        .unwrap_err()
        .to_string()
        .contains("trailing"));
    assert!(Rle
        .decode_lists(&bytes, &lim)
        .unwrap_err()
        .to_string()
        .contains("magic"));
    let mut b = bytes.clone();
    b[16..24].copy_from_slice(&[0xff, 0xff, 0, 0, 0xff, 0xff, 0, 0]);
    assert!(matches!(
        Raw.decode_lists(&b, &lim),
        Err(DecodeError::TooLarge { .. })
    ));
    // A huge segment count is refused before allocating.
    let mut b = bytes.clone();
    b[24..28].copy_from_slice(&60_000u32.to_le_bytes());
    assert!(matches!(
        Raw.decode_lists(&b, &lim),
        Err(DecodeError::Truncated { .. })
    ));
    assert!(canonical::is_clear(&s(1.0, 2.0, 0.0)));
}

#[test]
fn rle_is_smaller_on_sparse_regions() {
    let rect = Rect {
        x0: 0,
        y0: 0,
        x1: 100,
        y1: 100,
    };
    let mut raw_lists = vec![Vec::new(); 10_000];
    for (k, l) in raw_lists
        .iter_mut()
        .enumerate()
        .filter(|(k, _)| k % 37 == 0)
    {
        l.push(Segment {
            z_front: k as f32,
            z_back: k as f32 + 1.0,
            rgba: Rgba {
                rgb: [0.1; 3],
                a: 0.2,
            },
        });
    }
    let lists = RegionLists::canonical(rect, &raw_lists, true);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    Raw.encode_lists(&lists, &mut a);
    Rle.encode_lists(&lists, &mut b);
    assert!(b.len() * 3 < a.len(), "rle {} raw {}", b.len(), a.len());
}
