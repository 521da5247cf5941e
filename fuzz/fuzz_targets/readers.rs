//! Fuzzes the data readers: the first byte picks the reader (legacy VTK,
//! VTU, AVS UCD; NRRD, NIfTI, VTI, AVS field), the rest is the file. Any
//! bytes give a mesh or volume, or an error: never a panic.
//! Run: `cargo +nightly fuzz run readers` (from the repository root).
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use pvrsim::data::io::{avs_ucd, volume, vtk_legacy, vtu};

fuzz_target!(|data: &[u8]| {
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
});
