//! What per-slice LOD (slice-lod-memory.txt) costs in image quality:
//! slice2d at full resolution and with `--lod D` for each given `D`, each
//! compared (f32 images, max-abs and RMSE in 1/255) with the full-resolution
//! image and with the grid reference, beside the slice bytes held.
//!
//! ```text
//! cargo run --release --example lod_diff -- SCENE D1,D2,... [REF_CACHE]
//! ```

use std::path::Path;
use std::sync::Arc;

use pvrsim::render::slice2d::{self, Slice2dOptions};
use pvrsim::render::VolumeInput;
use pvrsim::scene::Scene;

#[path = "support/ref_cache.rs"]
mod ref_cache;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(
        args.len() >= 2,
        "usage: lod_diff SCENE D1,D2,... [REF_CACHE]"
    );
    let scene = Scene::load(Path::new(&args[0]))?;
    let vol = pvrsim::data::io::read_volume(&scene.data.path, &scene.data.field)?;
    let input = VolumeInput::new(scene, Arc::new(vol))?;
    let ds: Vec<f64> = args[1]
        .split(',')
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let refimg = ref_cache::reference(&input, args.get(2).map(|s| s.as_str()))?;
    let (full, sf) = slice2d::render(&input, &Slice2dOptions::default())?;
    let ef = full.error_against(&refimg);
    println!(
        "| D | slices per level | texture_bytes | vs full max / RMSE | vs reference max / RMSE |"
    );
    println!("| --- | --- | --- | --- | --- |");
    println!(
        "| off | {:?} | {} | 0 / 0 | {:.2} / {:.3} |",
        sf.slices_per_level.clone().unwrap_or_default(),
        sf.texture_bytes,
        ef.max_abs,
        ef.rmse
    );
    for d in ds {
        let o = Slice2dOptions {
            lod: Some(d),
            ..Default::default()
        };
        let (img, st) = slice2d::render(&input, &o)?;
        let (a, b) = (img.error_against(&full), img.error_against(&refimg));
        println!(
            "| {d} | {:?} | {} ({:.1}x less) | {:.2} / {:.3} | {:.2} / {:.3} |",
            st.slices_per_level.clone().unwrap_or_default(),
            st.texture_bytes,
            sf.texture_bytes as f64 / st.texture_bytes.max(1) as f64,
            a.max_abs,
            a.rmse,
            b.max_abs,
            b.rmse
        );
    }
    Ok(())
}
