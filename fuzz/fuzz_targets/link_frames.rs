//! Fuzzes the TCP link-frame decoder: any bytes give frames or an error,
//! never a panic, and no payload beyond the limit.
//! Run: `cargo +nightly fuzz run link_frames` (from the repository root).
//! The body is `bodies::link_frames` (`fuzz/bodies.rs`), which the stable test
//! `tests/fuzz_decoders.rs` runs too.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../bodies.rs"]
mod bodies;

fuzz_target!(|data: &[u8]| bodies::link_frames(data));
