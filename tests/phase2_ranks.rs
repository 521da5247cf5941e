//! Phase 2 worker to worker (`pvrsim::cluster::remote::phase2`): the per-rank executor over channels (one thread per rank and one for
//! the coordinator) against the in-process executor: the same image bit for
//! bit and the same counters, for both strategies, both codecs and several
//! node counts (including counts that are not powers of two).

use std::time::Duration;

use pvrsim::base::segment::{Rgba, Segment};
use pvrsim::base::Rect;
use pvrsim::cluster::remote::phase2::*;
use pvrsim::compositor::region::screen;
use pvrsim::compositor::{codec, run_local, strategy, ExecOptions, Payload, RegionLists};
use pvrsim::image::Image;
use pvrsim::net::channel::ChannelNetwork;
use pvrsim::net::{MessageKind, NodeId, Transport};

/// Node `k`'s lists of `n`: per pixel 0..3 segments at depths interleaved
/// with the other nodes' (node k owns depth slots `j n + k`), colours from
/// a fixed hash; empty pixels too.
fn lists(n: usize, k: usize, w: u32, h: u32) -> RegionLists {
    let mut px: Vec<Vec<Segment>> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let mut hsh = (x as u64 * 73856093) ^ (y as u64 * 19349663) ^ (k as u64 * 83492791);
            hsh = hsh
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let count = (hsh >> 60) as usize % 4;
            let v: Vec<Segment> = (0..count)
                .map(|j| {
                    let z = (j * n + k) as f32;
                    let a = (1 + ((hsh >> (8 * j)) & 0xff)) as f32 / 400.0;
                    Segment {
                        z_front: z,
                        z_back: z + 0.5,
                        rgba: Rgba {
                            rgb: [a * 0.9, a * 0.5, a * 0.1],
                            a,
                        },
                    }
                })
                .collect();
            px.push(v);
        }
    }
    RegionLists::from_canonical_fn(screen(w, h), |x, y| &px[(y * w + x) as usize])
}

fn bits(img: &Image) -> Vec<u32> {
    img.pixels
        .iter()
        .flat_map(|p| p.iter().map(|c| c.to_bits()))
        .collect()
}

#[test]
fn ranks_over_channels_give_the_in_process_image_and_counters() {
    let (w, h) = (37, 23);
    for strat in ["binary-swap", "direct-send"] {
        for codec_name in ["rle", "raw"] {
            for n in [1usize, 2, 3, 5, 8] {
                let s = strategy::from_name(strat).unwrap();
                let c = codec::from_name(codec_name).unwrap();
                let opts = ExecOptions {
                    background: [0.1, 0.2, 0.3],
                    ..Default::default()
                };
                let node_lists: Vec<RegionLists> = (0..n).map(|k| lists(n, k, w, h)).collect();
                let (want, want_stats) =
                    run_local(s.as_ref(), c.as_ref(), node_lists.clone(), opts).unwrap();
                let schedule = s.schedule(n, screen(w, h));
                let mut ends = ChannelNetwork::new(n + 1);
                let coord = ends.pop().unwrap();
                let logs: Vec<RankLog> = std::thread::scope(|sc| {
                    let hs: Vec<_> = ends
                        .iter()
                        .zip(node_lists)
                        .enumerate()
                        .map(|(k, (t, l))| {
                            let (schedule, opts) = (&schedule, &opts);
                            sc.spawn(move || {
                                let c = codec::from_name(codec_name).unwrap();
                                run_rank(
                                    t,
                                    k,
                                    NodeId::from(n),
                                    schedule,
                                    c.as_ref(),
                                    opts,
                                    l,
                                    Vec::new(),
                                    Duration::from_secs(30),
                                )
                                .unwrap()
                            })
                        })
                        .collect();
                    hs.into_iter().map(|h| h.join().unwrap()).collect()
                });
                let mut g = Gather::new(&schedule, c.as_ref(), opts);
                while let Some(e) = coord.try_recv().unwrap() {
                    assert_eq!(e.kind, MessageKind::Image);
                    g.take(e.from.index(), &e.payload).unwrap();
                }
                let img = g.image().unwrap();
                assert_eq!(bits(&img), bits(&want), "{strat} {codec_name} n={n}");
                let st = stats_from_logs(&schedule, s.name(), c.name(), &logs);
                assert_eq!(st, want_stats, "{strat} {codec_name} n={n}");
                assert!(logs[schedule.root].handoff_bytes > 0);
            }
        }
    }
}

#[test]
fn header_round_trips_and_rejects_bad_bytes() {
    let r = Rect {
        x0: 1,
        y0: 2,
        x1: 30,
        y1: 4,
    };
    for what in [Payload::Lists(r), Payload::Pixels(r)] {
        let m = encode_message(7, what, b"abc");
        assert_eq!(decode_message(&m).unwrap(), (7, what, &b"abc"[..]));
    }
    assert!(decode_message(&[0; HEADER_BYTES - 1]).is_err());
    let mut m = encode_message(0, Payload::Lists(r), b"");
    m[4] = 9;
    assert!(decode_message(&m).unwrap_err().contains("kind 9"));
    let mut m = encode_message(0, Payload::Lists(r), b"");
    m[5..9].copy_from_slice(&50u32.to_le_bytes());
    assert!(decode_message(&m).unwrap_err().contains("inverted"));
}

proptest::proptest! {
    /// Any bytes as a phase-2 message: a header and body, or an error;
    /// never a panic. Any bytes as gathered pixels: an error or pixels
    /// inside the image; never a panic (the fuzz target `phase2_message`
    /// runs the same two decoders).
    #[test]
    fn arbitrary_phase2_bytes_never_panic(
        bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..160)
    ) {
        if let Ok((_, what, body)) = decode_message(&bytes) {
            proptest::prop_assert_eq!(body.len(), bytes.len() - HEADER_BYTES);
            proptest::prop_assert!(what.rect().x0 <= what.rect().x1);
        }
        let s = strategy::from_name("binary-swap").unwrap().schedule(2, screen(8, 8));
        let c = codec::from_name("rle").unwrap();
        let mut g = Gather::new(&s, c.as_ref(), ExecOptions::default());
        let _ = g.take(1, &bytes);
        let _ = g.image();
    }
}
