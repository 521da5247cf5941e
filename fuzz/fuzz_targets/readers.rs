//! Fuzzes the data readers: the first byte picks the reader (legacy VTK,
//! VTU, AVS UCD; NRRD, NIfTI, VTI, AVS field), the rest is the file. Any
//! bytes give a mesh or volume, or an error: never a panic.
//! Run: `cargo +nightly fuzz run readers` (from the repository root).
//! The body is `bodies::readers` (`fuzz/bodies.rs`), which the stable test
//! `tests/fuzz_decoders.rs` runs too.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../bodies.rs"]
mod bodies;

fuzz_target!(|data: &[u8]| bodies::readers(data));
