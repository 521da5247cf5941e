//! The grid reference of a scene, cached as raw little-endian f32 RGBA in a
//! file so that repeated diagnostic runs skip the slow oracle. Shared by the
//! grid examples (`#[path = "support/ref_cache.rs"] mod ref_cache;`).

use pvrsim::image::Image;
use pvrsim::render::{grid_reference, VolumeInput};

/// The grid reference image of `input`: read from `cache` when that file
/// holds exactly one image of the scene's size, else rendered (and written
/// to `cache` when one is named).
pub fn reference(input: &VolumeInput, cache: Option<&str>) -> anyhow::Result<Image> {
    let (w, h) = (input.scene.image.width, input.scene.image.height);
    let want = w as usize * h as usize * 16;
    if let Some(b) = cache.and_then(|p| std::fs::read(p).ok()) {
        if b.len() == want {
            let mut img = Image::new(w, h);
            let vals = b
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]));
            for (v, x) in img.pixels.iter_mut().flatten().zip(vals) {
                *v = x;
            }
            return Ok(img);
        }
        eprintln!(
            "reference cache: {} bytes, not {want}; rendering again",
            b.len()
        );
    }
    let (img, _) = grid_reference::render(input, &Default::default());
    if let Some(p) = cache {
        let b: Vec<u8> = img
            .pixels
            .iter()
            .flat_map(|px| px.iter().flat_map(|v| v.to_le_bytes()))
            .collect();
        std::fs::write(p, b).map_err(|e| anyhow::anyhow!("cannot write {p}: {e}"))?;
    }
    Ok(img)
}
