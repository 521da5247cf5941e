//! Fuzzes the decoders of phase 2 worker to worker: the message header
//! (`decode_message`) and the gathered pixels the coordinator takes
//! (`Gather::take`): any bytes give a message or an error, never a panic.
//! Run: `cargo +nightly fuzz run phase2_message` (from the repository root).
//! The body is `bodies::phase2_message` (`fuzz/bodies.rs`), which the stable test
//! `tests/fuzz_decoders.rs` runs too.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../bodies.rs"]
mod bodies;

fuzz_target!(|data: &[u8]| bodies::phase2_message(data));
