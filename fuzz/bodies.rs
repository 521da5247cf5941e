//! The bodies of the fuzz targets, one plain function per target, so that
//! the same checks run under cargo-fuzz (nightly, `fuzz_targets/*.rs`) and
//! under a stable test (`tests/fuzz_decoders.rs`), which both include this
//! file with `#[path]`. See `fuzz/README.md`.
//!
//! Each function takes any bytes and must return without panicking; the
//! asserts inside are the properties a target checks.

// Each fuzz binary uses one of these; the stable test uses all of them.
#![allow(dead_code)]

use std::path::Path;

use pvrsim::cluster::remote::phase2::{decode_message, Gather};
use pvrsim::cluster::remote::session::Session;
use pvrsim::compositor::region::screen;
use pvrsim::compositor::{codec, strategy, ExecOptions};
use pvrsim::data::io::{avs_ucd, volume, vtk_legacy, vtu};
use pvrsim::net::tcp::{decode_all, LinkFrame};
use pvrsim::net::Codec;
use pvrsim::node::WorkUnit;

/// Payload limit of the codecs in `link_frames` and `session`.
pub const LIMIT: u64 = 1 << 16;

/// The TCP link-frame decoder: any bytes give frames or an error, never a
/// panic, and no payload beyond the limit.
pub fn link_frames(data: &[u8]) {
    let codec = Codec::with_limit(LIMIT);
    let (frames, _err) = decode_all(data, &codec);
    for f in frames {
        if let LinkFrame::Data(e) = f {
            assert!(e.payload.len() <= 1 << 16);
        }
    }
}

/// The decoders of phase 2 worker to worker: the message header
/// (`decode_message`) and the gathered pixels the coordinator takes
/// (`Gather::take`): any bytes give a message or an error, never a panic.
pub fn phase2_message(data: &[u8]) {
    let _ = decode_message(data);
    let s = strategy::from_name("binary-swap")
        .expect("known strategy")
        .schedule(3, screen(16, 16));
    let c = codec::from_name("rle").expect("known codec");
    let mut g = Gather::new(&s, c.as_ref(), ExecOptions::default());
    let _ = g.take(1, data);
    let _ = g.image();
}

/// The data readers: the first byte picks the reader (legacy VTK, VTU, AVS
/// UCD; NRRD, NIfTI, VTI, AVS field), the rest is the file. Any bytes give
/// a mesh or volume, or an error: never a panic.
pub fn readers(data: &[u8]) {
    let Some((&pick, file)) = data.split_first() else {
        return;
    };
    let p = Path::new("fuzz");
    match pick % 7 {
        0 => drop(vtk_legacy::parse(file, p)),
        1 => drop(vtu::parse(file, p)),
        2 => {
            if let Ok(text) = std::str::from_utf8(file) {
                drop(avs_ucd::parse(text, p));
            }
        }
        3 => drop(volume::nrrd::parse(file, p, "")),
        4 => drop(volume::nifti::parse(file, p, "")),
        5 => drop(volume::vti::parse(file, p, "")),
        _ => drop(volume::avs_field::parse(file, p, "")),
    }
}

/// What a worker reads from the coordinator before it trusts it: the
/// session messages (set-up, cells, results) under the size-limited codec,
/// the set-up's validation, and the cells (`WorkUnit::decode`). Any bytes
/// give a value or an error: never a panic, never an allocation past the
/// codec's limit.
pub fn session(data: &[u8]) {
    let codec = Codec::with_limit(LIMIT);
    if let Ok(Session::Setup(s)) = codec.decode::<Session>(data) {
        let _ = s.validate();
    }
    let _ = WorkUnit::decode(data);
}

/// A target's body.
pub type Body = fn(&[u8]);

/// Every target: its name (also its corpus folder, `fuzz/corpus/<name>/`)
/// and its body.
pub const TARGETS: [(&str, Body); 4] = [
    ("link_frames", link_frames),
    ("phase2_message", phase2_message),
    ("readers", readers),
    ("session", session),
];
