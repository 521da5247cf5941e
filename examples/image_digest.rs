//! Prints a digest of the bits of the cell renderer's image for a scene, to
//! check that a change leaves an image bit-for-bit unchanged:
//!
//! ```text
//! cargo run --release --example image_digest -- tests/data/aorta-small-view-b.toml
//! ```
//!
//! One line per setting: ERT off and the default ERT, each with and without
//! partial composition; FNV-1a over every pixel's four f32 bit patterns.

use std::path::Path;

use pvrsim::render::cell::{self, CellOptions, ErtOptions};
use pvrsim::render::RenderInput;

fn digest(px: &[[f32; 4]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for p in px {
        for c in p {
            for b in c.to_bits().to_le_bytes() {
                h ^= u64::from(b);
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        }
    }
    h
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(!args.is_empty(), "usage: image_digest SCENE.toml...");
    for scene in &args {
        let (input, _) = RenderInput::load(Path::new(scene))?;
        for (name, ert) in [
            ("ert-off", ErtOptions::OFF),
            ("ert-default", ErtOptions::DEFAULT),
        ] {
            for partial in [true, false] {
                let opts = CellOptions {
                    ert,
                    partial_composition: partial,
                    ..Default::default()
                };
                let (img, _) = cell::render(&input, &opts);
                println!(
                    "{scene} {name} partial={partial} {:016x}",
                    digest(&img.pixels)
                );
            }
        }
    }
    Ok(())
}
