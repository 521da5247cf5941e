//! Floating-point RGB images, PNG output, and the image-error metric used for
//! every accuracy claim: max-abs and RMSE per channel, in 1/255 units.

use std::path::Path;

use crate::error::{Error, Result};

/// A linear RGBA image, row-major, row 0 at the top. RGB is the final colour
/// (already composited over the background); A is the volume's opacity.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels.
    pub pixels: Vec<[f32; 4]>,
}

/// Difference between two images, in 1/255 units, over the RGB channels
/// ([`Image::error_against`]) or all four ([`Image::error_against_rgba`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ImageError {
    /// Largest absolute difference of any channel of any pixel.
    pub max_abs: f64,
    /// Root-mean-square difference over all pixels and the channels compared.
    pub rmse: f64,
    /// Pixels whose largest channel difference exceeds 1/255.
    pub pixels_over_1: usize,
    /// Where `max_abs` occurs, `(i, j)`.
    pub worst_pixel: (u32, u32),
}

impl std::fmt::Display for ImageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "max-abs {:.3}/255 at {:?}, RMSE {:.3}/255, {} pixels over 1/255",
            self.max_abs, self.worst_pixel, self.rmse, self.pixels_over_1
        )
    }
}

impl Image {
    /// A blank (all zero) image.
    pub fn new(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            pixels: vec![[0.0; 4]; width as usize * height as usize],
        }
    }

    /// Pixel `(i, j)`.
    pub fn get(&self, i: u32, j: u32) -> [f32; 4] {
        self.pixels[j as usize * self.width as usize + i as usize]
    }

    /// 8-bit RGB bytes, rounded, clamped to [0, 1].
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| [p[0], p[1], p[2]])
            .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect()
    }

    /// The 8-bit RGB PNG [`Image::save_png`] writes, as bytes (the one PNG
    /// writer: the live viewer serves these bytes, `pvrsim render` writes
    /// them to a file).
    pub fn png_bytes(&self) -> std::result::Result<Vec<u8>, image::ImageError> {
        use image::ImageEncoder;
        let mut out = Vec::new();
        image::codecs::png::PngEncoder::new(&mut out).write_image(
            &self.to_rgb8(),
            self.width,
            self.height,
            image::ExtendedColorType::Rgb8,
        )?;
        Ok(out)
    }

    /// Writes an 8-bit RGB PNG ([`Image::png_bytes`]).
    pub fn save_png(&self, path: &Path) -> Result<()> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        let bytes = self
            .png_bytes()
            .map_err(|e| Error::io(path, std::io::Error::other(e)))?;
        std::fs::write(path, bytes).map_err(|e| Error::io(path, e))
    }

    /// Whether any channel of any pixel is NaN or infinite.
    pub fn has_non_finite(&self) -> bool {
        self.pixels.iter().any(|p| p.iter().any(|v| !v.is_finite()))
    }

    /// Error of `self` against `reference` (same size), RGB channels, 1/255 units.
    /// A NaN difference makes `max_abs` (and `rmse`) NaN.
    pub fn error_against(&self, reference: &Image) -> ImageError {
        self.error_over(reference, 3)
    }

    /// [`Image::error_against`] over all four channels, alpha included
    /// (1/255 units): for partial images, whose coverage is in alpha.
    pub fn error_against_rgba(&self, reference: &Image) -> ImageError {
        self.error_over(reference, 4)
    }

    /// The error over the first `channels` channels.
    fn error_over(&self, reference: &Image, channels: usize) -> ImageError {
        assert_eq!(
            (self.width, self.height),
            (reference.width, reference.height),
            "images differ in size"
        );
        let mut max_abs = 0.0f64;
        let mut worst = 0usize;
        let mut sum2 = 0.0f64;
        let mut over = 0usize;
        for (k, (a, b)) in self.pixels.iter().zip(&reference.pixels).enumerate() {
            let mut pmax = 0.0f64;
            for c in 0..channels {
                let d = (a[c] as f64 - b[c] as f64).abs() * 255.0;
                sum2 += d * d;
                if d > pmax || d.is_nan() {
                    pmax = d;
                }
            }
            if pmax > 1.0 {
                over += 1;
            }
            if (pmax > max_abs || pmax.is_nan()) && !max_abs.is_nan() {
                max_abs = pmax;
                worst = k;
            }
        }
        let n = (self.pixels.len() * channels).max(1) as f64;
        ImageError {
            max_abs,
            rmse: (sum2 / n).sqrt(),
            pixels_over_1: over,
            worst_pixel: (
                (worst % self.width as usize) as u32,
                (worst / self.width as usize) as u32,
            ),
        }
    }

    /// `|a - b| * gain` per channel, alpha 1: where two renderers disagree.
    pub fn difference(a: &Image, b: &Image, gain: f32) -> Image {
        let pixels = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(p, q)| {
                [
                    (p[0] - q[0]).abs() * gain,
                    (p[1] - q[1]).abs() * gain,
                    (p[2] - q[2]).abs() * gain,
                    1.0,
                ]
            })
            .collect();
        Image {
            width: a.width,
            height: a.height,
            pixels,
        }
    }

    /// Puts `images` side by side (same height) with a gap, for looking at
    /// two renderers next to each other.
    pub fn side_by_side(images: &[&Image], gap: u32) -> Image {
        let h = images.iter().map(|i| i.height).max().unwrap_or(0);
        let w = images.iter().map(|i| i.width).sum::<u32>()
            + gap * images.len().saturating_sub(1) as u32;
        let mut out = Image::new(w, h);
        for p in &mut out.pixels {
            *p = [1.0, 1.0, 1.0, 1.0];
        }
        let mut x0 = 0;
        for im in images {
            for j in 0..im.height {
                for i in 0..im.width {
                    out.pixels[(j * w + x0 + i) as usize] = im.get(i, j);
                }
            }
            x0 += im.width + gap;
        }
        out
    }
}
