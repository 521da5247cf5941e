//! Fuzzes what a worker reads from the coordinator before it trusts it:
//! the session messages (set-up, cells, results) under the size-limited
//! codec, the set-up's validation, and the cells (`WorkUnit::decode`).
//! Any bytes give a value or an error: never a panic, never an allocation
//! past the codec's limit.
//! Run: `cargo +nightly fuzz run session` (from the repository root).
#![no_main]

use libfuzzer_sys::fuzz_target;
use pvrsim::cluster::remote::session::Session;
use pvrsim::net::Codec;
use pvrsim::node::WorkUnit;

fuzz_target!(|data: &[u8]| {
    let codec = Codec::with_limit(1 << 16);
    if let Ok(Session::Setup(s)) = codec.decode::<Session>(data) {
        let _ = s.validate();
    }
    let _ = WorkUnit::decode(data);
});
