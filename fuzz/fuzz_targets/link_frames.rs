//! Fuzzes the TCP link-frame decoder: any bytes give frames or an error,
//! never a panic, and no payload beyond the limit.
//! Run: `cargo +nightly fuzz run link_frames` (from the repository root).
#![no_main]

use libfuzzer_sys::fuzz_target;
use pvrsim::net::tcp::{decode_all, LinkFrame};
use pvrsim::net::Codec;

fuzz_target!(|data: &[u8]| {
    let codec = Codec::with_limit(1 << 16);
    let (frames, _err) = decode_all(data, &codec);
    for f in frames {
        if let LinkFrame::Data(e) = f {
            assert!(e.payload.len() <= 1 << 16);
        }
    }
});
