//! Fuzzes the decoders of phase 2 worker to worker: the message header
//! (`decode_message`) and the gathered pixels the coordinator takes
//! (`Gather::take`): any bytes give a message or an error, never a panic.
//! Run: `cargo +nightly fuzz run phase2_message` (from the repository root).
#![no_main]

use libfuzzer_sys::fuzz_target;
use pvrsim::cluster::remote::phase2::{decode_message, Gather};
use pvrsim::compositor::region::screen;
use pvrsim::compositor::{codec, strategy, ExecOptions};

fuzz_target!(|data: &[u8]| {
    let _ = decode_message(data);
    let s = strategy::from_name("binary-swap")
        .expect("known strategy")
        .schedule(3, screen(16, 16));
    let c = codec::from_name("rle").expect("known codec");
    let mut g = Gather::new(&s, c.as_ref(), ExecOptions::default());
    let _ = g.take(1, data);
    let _ = g.image();
});
