//! Round trips, canonical bytes, size bounds and fuzzed input for the layer
//! codecs.

use proptest::prelude::*;

use super::*;
use crate::compositor::codec::layer_codec as from_name;
use crate::compositor::codec::HEADER_BYTES;

/// A premultiplied pixel at `depth`: `A = 0` (transparent) or `RGB <= A`.
fn pixel(depth: Depth) -> impl Strategy<Value = [u16; 4]> {
    let m = depth.max() as u32;
    prop_oneof![
        2 => Just([0u16; 4]),
        1 => (1..=m, any::<[u16; 3]>()).prop_map(move |(a, c)| [
            (c[0] as u32 % (m + 1) * a / m) as u16,
            (c[1] as u32 % (m + 1) * a / m) as u16,
            (c[2] as u32 % (m + 1) * a / m) as u16,
            a as u16
        ]),
    ]
}

fn layer() -> impl Strategy<Value = Layer> {
    (
        0u32..12,
        0u32..12,
        0u32..40,
        0u32..40,
        0u32..20,
        0u32..3,
        any::<bool>(),
    )
        .prop_flat_map(|(w, h, x0, y0, lo, span, wide)| {
            let depth = if wide { Depth::U16 } else { Depth::U8 };
            prop::collection::vec(pixel(depth), (w * h) as usize).prop_map(move |px| Layer {
                rect: Rect {
                    x0,
                    y0,
                    x1: x0 + w,
                    y1: y0 + h,
                },
                ranks: [lo, lo + span],
                depth,
                px,
            })
        })
}

/// Every codec carrying layers of `depth`.
fn codecs(depth: Depth) -> Vec<Box<dyn LayerCodec>> {
    list()
        .iter()
        .map(|(n, _)| from_name(n).unwrap())
        .filter(|c| c.depth() == depth)
        .collect()
}

/// Every codec.
fn all_codecs() -> Vec<Box<dyn LayerCodec>> {
    list().iter().map(|(n, _)| from_name(n).unwrap()).collect()
}

fn enc(c: &dyn LayerCodec, l: &Layer) -> Vec<u8> {
    let mut b = Vec::new();
    c.encode(l, &mut b);
    b
}

proptest! {
    #[test]
    fn round_trip_exact_and_canonical(l in layer()) {
        for c in codecs(l.depth) {
            let b = enc(c.as_ref(), &l);
            let back = c.decode(&b, &Limits::default()).unwrap();
            prop_assert_eq!(&back, &l, "codec {}", c.name());
            prop_assert_eq!(&enc(c.as_ref(), &back), &b, "codec {} not canonical", c.name());
            prop_assert!(b.len() as u64 <= raw_bytes(&l), "codec {} above raw", c.name());
        }
    }

    #[test]
    fn mutated_bytes_never_panic(l in layer(), at in any::<prop::sample::Index>(), v in any::<u8>(), cut in any::<prop::sample::Index>()) {
        for c in codecs(l.depth) {
            let good = enc(c.as_ref(), &l);
            let k = cut.index(good.len());
            prop_assert!(c.decode(&good[..k], &Limits::default()).is_err(), "codec {}: prefix {k} decoded", c.name());
            let mut b = good;
            let i = at.index(b.len());
            b[i] = v;
            if let Ok(back) = c.decode(&b, &Limits::default()) {
                // Whatever decodes must re-encode to the same bytes (or be a
                // raw message that `sparse` accepts as its fallback).
                let again = enc(c.as_ref(), &back);
                prop_assert!(again == b || b[3] == b'8' || b[3] == b'6', "codec {}", c.name());
            }
        }
    }
}

fn checkerboard(w: u32, h: u32, depth: Depth) -> Layer {
    let px = (0..w * h)
        .map(|i| {
            if (i % w + i / w).is_multiple_of(2) {
                [10, 20, 30, 40]
            } else {
                [0; 4]
            }
        })
        .collect();
    Layer {
        rect: Rect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        },
        ranks: [0, 0],
        depth,
        px,
    }
}

#[test]
fn checkerboard_is_bounded_by_raw_plus_header() {
    for depth in [Depth::U8, Depth::U16] {
        let l = checkerboard(63, 33, depth);
        let raw = raw_bytes(&l);
        for c in codecs(depth) {
            let n = enc(c.as_ref(), &l).len() as u64;
            assert!(n <= raw, "{}: {n} > raw {raw}", c.name());
        }
        // The paper's RLE: exactly one word per pixel on a checkerboard.
        assert_eq!(enc(&Rle(depth), &l).len() as u64, raw);
        assert_eq!(
            raw,
            (LAYER_HEADER_BYTES + depth.pixel_bytes() * 63 * 33) as u64
        );
    }
}

#[test]
fn a_codec_rounds_a_layer_of_another_depth_to_its_own() {
    let mut l = checkerboard(5, 3, Depth::U16);
    l.px[0] = [257 * 10, 257 * 20, 257 * 30 + 100, 257 * 40 + 128];
    for c in all_codecs() {
        let back = c.decode(&enc(c.as_ref(), &l), &Limits::default()).unwrap();
        assert_eq!(back.depth, c.depth(), "{}", c.name());
        assert_eq!(back.ranks, l.ranks);
        let want = match c.depth() {
            Depth::U16 => l.px[0],
            Depth::U8 => [10, 20, 30, 40],
        };
        assert_eq!(back.px[0], want, "{}", c.name());
    }
}

#[test]
fn empty_frame_compresses_to_a_few_words() {
    for depth in [Depth::U8, Depth::U16] {
        let l = Layer::empty(
            Rect {
                x0: 0,
                y0: 0,
                x1: 512,
                y1: 512,
            },
            3,
            depth,
        );
        assert_eq!(
            enc(&Rle(depth), &l).len(),
            LAYER_HEADER_BYTES + depth.pixel_bytes()
        );
        assert_eq!(enc(&Sparse(depth), &l).len(), LAYER_HEADER_BYTES + 4);
    }
    assert_eq!(HEADER_BYTES + 8, LAYER_HEADER_BYTES);
}

#[test]
fn runs_longer_than_24_bits_are_split() {
    // 4100^2 = 16,810,000 > 2^24 - 1 = 16,777,215 transparent pixels.
    let l = Layer::empty(
        Rect {
            x0: 0,
            y0: 0,
            x1: 4100,
            y1: 4100,
        },
        0,
        Depth::U8,
    );
    let b = enc(&Rle(Depth::U8), &l);
    assert_eq!(b.len(), LAYER_HEADER_BYTES + 8);
    let w = &b[LAYER_HEADER_BYTES..];
    assert_eq!(&w[..4], &[0xff, 0xff, 0xff, 0]);
    assert_eq!(
        u32::from_le_bytes([w[4], w[5], w[6], 0]),
        16_810_000 - 16_777_215
    );
    let lim = Limits {
        max_pixels: 1 << 25,
        ..Limits::default()
    };
    assert_eq!(Rle(Depth::U8).decode(&b, &lim).unwrap(), l);
    // Two short runs in a row are not canonical.
    let mut bad = b[..LAYER_HEADER_BYTES].to_vec();
    bad.extend_from_slice(&[0xfe, 0xff, 0xff, 0]);
    bad.extend_from_slice(&[0x11, 0x80, 0x00, 0]);
    bad.extend_from_slice(&[0x01, 0x00, 0x00, 0]);
    assert!(Rle(Depth::U8).decode(&bad, &lim).is_err());
    // At 16 bits one word holds the whole run: 2^48 - 1 > 16,810,000.
    let mut l16 = l;
    l16.depth = Depth::U16;
    let b = enc(&Rle(Depth::U16), &l16);
    assert_eq!(b.len(), LAYER_HEADER_BYTES + 8);
    assert_eq!(Rle(Depth::U16).decode(&b, &lim).unwrap(), l16);
}

#[test]
fn non_premultiplied_and_bad_runs_are_rejected() {
    let mut l = Layer::empty(
        Rect {
            x0: 0,
            y0: 0,
            x1: 3,
            y1: 1,
        },
        0,
        Depth::U8,
    );
    l.px[1] = [9, 9, 9, 9];
    let rle = Rle(Depth::U8);
    let good = enc(&rle, &l);
    // [1,0,0,0] run, [9,9,9,9] pixel, [1,0,0,0] run.
    let mut b = good.clone();
    b[LAYER_HEADER_BYTES + 4] = 10; // R > A
    let e = rle.decode(&b, &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("premultiplied"), "{e}");
    let mut b = good.clone();
    b[LAYER_HEADER_BYTES] = 0; // run of length 0
    assert!(rle
        .decode(&b, &Limits::default())
        .unwrap_err()
        .to_string()
        .contains("length 0"));
    let mut b = good.clone();
    b[LAYER_HEADER_BYTES + 8] = 2; // overrun
    assert!(rle
        .decode(&b, &Limits::default())
        .unwrap_err()
        .to_string()
        .contains("overruns"));
    let mut b = good;
    b.push(0);
    assert!(rle
        .decode(&b, &Limits::default())
        .unwrap_err()
        .to_string()
        .contains("trailing"));
}

#[test]
fn rle16_rejects_non_premultiplied_and_zero_runs() {
    let mut l = Layer::empty(
        Rect {
            x0: 0,
            y0: 0,
            x1: 3,
            y1: 1,
        },
        0,
        Depth::U16,
    );
    l.px[1] = [900, 9, 9, 1000];
    let rle = Rle(Depth::U16);
    let good = enc(&rle, &l);
    assert_eq!(good.len(), LAYER_HEADER_BYTES + 3 * 8);
    assert_eq!(rle.decode(&good, &Limits::default()).unwrap(), l);
    let mut b = good.clone();
    b[LAYER_HEADER_BYTES + 8 + 1] = 0x04; // R = 900 + 1024 > A = 1000
    let e = rle.decode(&b, &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("premultiplied"), "{e}");
    let mut b = good;
    b[LAYER_HEADER_BYTES] = 0; // run of length 0
    let e = rle.decode(&b, &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("length 0"), "{e}");
}
