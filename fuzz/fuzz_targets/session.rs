//! Fuzzes what a worker reads from the coordinator before it trusts it:
//! the session messages (set-up, cells, results) under the size-limited
//! codec, the set-up's validation, and the cells (`WorkUnit::decode`).
//! Any bytes give a value or an error: never a panic, never an allocation
//! past the codec's limit.
//! Run: `cargo +nightly fuzz run session` (from the repository root).
//! The body is `bodies::session` (`fuzz/bodies.rs`), which the stable test
//! `tests/fuzz_decoders.rs` runs too.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../bodies.rs"]
mod bodies;

fuzz_target!(|data: &[u8]| bodies::session(data));
