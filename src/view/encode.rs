//! Frames as bytes for the page: JPEG while the user moves (small, fast),
//! a fast lossless PNG when still (the same pixels as the PNG `pvrsim
//! render` writes, [`Image::png_bytes`], which `/frame.png` serves, at a
//! lower compression level). docs/viewer.md has the measured encode times.

use crate::image::Image;

/// How a frame travels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameFormat {
    /// JPEG (lossy): frames drawn while the user interacts.
    Jpeg,
    /// PNG (lossless, fast compression): still frames.
    Png,
}

impl FrameFormat {
    /// The MIME type.
    pub fn mime(self) -> &'static str {
        match self {
            FrameFormat::Jpeg => "image/jpeg",
            FrameFormat::Png => "image/png",
        }
    }
}

/// JPEG quality of interactive frames.
pub const JPEG_QUALITY: u8 = 85;

/// Encodes `image` as `format`.
pub fn encode(image: &Image, format: FrameFormat) -> anyhow::Result<Vec<u8>> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let mut out = Vec::new();
    match format {
        FrameFormat::Png => write_rgb(
            PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Sub),
            image,
        )?,
        FrameFormat::Jpeg => write_rgb(
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, JPEG_QUALITY),
            image,
        )?,
    }
    Ok(out)
}

/// Writes `image` as 8-bit RGB through `encoder`.
fn write_rgb(encoder: impl image::ImageEncoder, image: &Image) -> anyhow::Result<()> {
    encoder.write_image(
        &image.to_rgb8(),
        image.width,
        image.height,
        image::ExtendedColorType::Rgb8,
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_formats_decode_to_the_frame_size() {
        let mut img = Image::new(40, 30);
        for (k, p) in img.pixels.iter_mut().enumerate() {
            *p = [(k % 40) as f32 / 40.0, 0.5, 0.2, 1.0];
        }
        for f in [FrameFormat::Jpeg, FrameFormat::Png] {
            let bytes = encode(&img, f).unwrap();
            let d = image::load_from_memory(&bytes).unwrap();
            assert_eq!((d.width(), d.height()), (40, 30), "{f:?}");
        }
        let png = image::load_from_memory(&encode(&img, FrameFormat::Png).unwrap())
            .unwrap()
            .to_rgb8();
        assert_eq!(png.into_raw(), img.to_rgb8(), "PNG is lossless");
    }
}
