//! Round trips and hostile input for the codec and frames.

use proptest::prelude::*;
use serde::{Deserialize, Serialize};

use crate::net::{Codec, Envelope, Message, MessageKind, NetError, NodeId, FRAME_HEADER_BYTES};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Grant {
    cells: Vec<[u32; 4]>,
    vertices: Vec<[f32; 4]>,
    note: String,
}
impl Message for Grant {
    const KIND: MessageKind = MessageKind::WorkGrant;
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Ert {
    terminated: Vec<bool>,
    deepest: Vec<f32>,
}
impl Message for Ert {
    const KIND: MessageKind = MessageKind::ErtShare;
}

fn grant() -> Grant {
    Grant {
        cells: vec![[0, 1, 2, 3], [4, 5, 6, 7]],
        vertices: vec![[0.5, -1.0, 2.0, 0.25]; 8],
        note: "two tets".into(),
    }
}

#[test]
fn round_trip_typed() {
    let c = Codec::default();
    let bytes = c.encode(&grant()).unwrap();
    assert_eq!(c.decode::<Grant>(&bytes).unwrap(), grant());
}

#[test]
fn fixint_sizes_match_raw_arrays() {
    // 20 entries: 8-byte length + 20 bools, 8-byte length + 20 f32.
    let m = Ert {
        terminated: vec![true; 20],
        deepest: vec![1.0; 20],
    };
    let bytes = Codec::default().encode(&m).unwrap();
    assert_eq!(bytes.len(), 8 + 20 + 8 + 4 * 20);
}

#[test]
fn envelope_checks_kind() {
    let c = Codec::default();
    let env = Envelope {
        from: NodeId(1),
        to: NodeId(0),
        kind: MessageKind::ErtShare,
        payload: c.encode(&grant()).unwrap(),
    };
    match env.decode::<Grant>(&c) {
        Err(NetError::WrongKind { expected, found }) => {
            assert_eq!(expected, MessageKind::WorkGrant);
            assert_eq!(found, MessageKind::ErtShare);
        }
        other => panic!("expected WrongKind, got {other:?}"),
    }
}

#[test]
fn truncated_payload_is_an_error_naming_the_kind() {
    let c = Codec::default();
    let bytes = c.encode(&grant()).unwrap();
    for cut in 0..bytes.len() {
        let err = c.decode::<Grant>(&bytes[..cut]).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("work-grant"), "{msg}");
    }
}

#[test]
fn trailing_bytes_are_rejected() {
    let c = Codec::default();
    let mut bytes = c.encode(&grant()).unwrap();
    bytes.push(0);
    assert!(c.decode::<Grant>(&bytes).is_err());
}

#[test]
fn oversized_length_prefix_does_not_allocate() {
    // A Vec length prefix of 2^60 elements in a 16-byte payload: bincode
    // preallocates at most a small bounded number of elements and then runs
    // out of input.
    let mut bytes = (1u64 << 60).to_le_bytes().to_vec();
    bytes.extend_from_slice(&[0; 8]);
    let msg = Codec::default()
        .decode::<Ert>(&bytes)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("ert-share"), "{msg}");
    // A string (byte buffer) announcing 2^60 bytes is refused before any
    // allocation: the announced length exceeds what the payload holds.
    let mut bytes = (1u64 << 60).to_le_bytes().to_vec();
    bytes.extend_from_slice(b"abc");
    let msg = Codec::default()
        .decode_as::<String>(MessageKind::Control, &bytes)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("control") && msg.contains("truncated"),
        "{msg}"
    );
}

#[test]
fn limit_is_enforced_both_ways() {
    let small = Codec::with_limit(64);
    let big = Ert {
        terminated: vec![false; 100],
        deepest: vec![0.0; 100],
    };
    match small.encode(&big) {
        Err(NetError::TooLarge { kind, size, limit }) => {
            assert_eq!(kind, MessageKind::ErtShare);
            assert_eq!(size, 8 + 100 + 8 + 400);
            assert_eq!(limit, 64);
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
    let bytes = Codec::default().encode(&big).unwrap();
    assert!(matches!(
        small.decode::<Ert>(&bytes),
        Err(NetError::TooLarge { .. })
    ));
}

#[test]
fn frame_round_trip_and_bad_headers() {
    let c = Codec::default();
    let env = Envelope {
        from: NodeId(3),
        to: NodeId(8),
        kind: MessageKind::Segments,
        payload: vec![1, 2, 3, 4, 5],
    };
    let frame = c.encode_frame(&env).unwrap();
    assert_eq!(frame.len(), FRAME_HEADER_BYTES + 5);
    assert_eq!(c.decode_frame(&frame).unwrap(), env);

    // Short header.
    assert!(matches!(
        c.decode_frame(&frame[..10]),
        Err(NetError::Frame(_))
    ));
    // Unknown kind code.
    let mut bad = frame.clone();
    bad[8] = 200;
    assert!(matches!(c.decode_frame(&bad), Err(NetError::Frame(_))));
    // Length prefix beyond the limit.
    let mut bad = frame.clone();
    bad[9..17].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(matches!(
        c.decode_frame(&bad),
        Err(NetError::TooLarge { .. })
    ));
    // Length prefix disagreeing with the body.
    let mut bad = frame.clone();
    bad[9..17].copy_from_slice(&6u64.to_le_bytes());
    let msg = c.decode_frame(&bad).unwrap_err().to_string();
    assert!(
        msg.contains("segments") && msg.contains("announces 6"),
        "{msg}"
    );
}

#[test]
fn kind_codes_round_trip() {
    for k in MessageKind::ALL {
        assert_eq!(MessageKind::from_code(k.code()), Some(k));
    }
    assert_eq!(MessageKind::from_code(8), None);
}

proptest! {
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        let c = Codec::with_limit(1 << 20);
        let _ = c.decode::<Grant>(&bytes);
        let _ = c.decode::<Ert>(&bytes);
        let _ = c.decode_frame(&bytes);
    }

    #[test]
    fn round_trip_any_grant(
        cells in proptest::collection::vec(any::<[u32; 4]>(), 0..50),
        vertices in proptest::collection::vec(any::<[f32; 4]>(), 0..50),
        note in ".{0,20}",
    ) {
        let g = Grant { cells, vertices, note };
        let c = Codec::default();
        let back = c.decode::<Grant>(&c.encode(&g).unwrap()).unwrap();
        // Compare bit patterns so NaN round trips count as equal.
        prop_assert_eq!(back.cells, g.cells);
        let bits = |v: &Vec<[f32; 4]>| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        prop_assert_eq!(bits(&back.vertices), bits(&g.vertices));
        prop_assert_eq!(back.note, g.note);
    }

    #[test]
    fn mutated_frames_never_panic(pos in 0usize..40, byte in any::<u8>()) {
        let c = Codec::default();
        let env = Envelope { from: NodeId(1), to: NodeId(2), kind: MessageKind::Image,
                             payload: c.encode(&grant()).unwrap() };
        let mut frame = c.encode_frame(&env).unwrap();
        let i = pos % frame.len();
        frame[i] = byte;
        if let Ok(e) = c.decode_frame(&frame) {
            let _ = c.decode_as::<Grant>(e.kind, &e.payload);
        }
    }
}
