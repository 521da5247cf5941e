//! The compute-time model of a grid node (virtual clock), from the
//! [`CostProfile`]:
//!
//! - with a device (`fill_rate > 0`): fill `F / fill_rate`, where `F` is the
//!   fragments drawn (every slice sample inside the brick: a GPU neither
//!   skips empty blocks nor terminates rays early); texture upload of the
//!   bricks that do not fit in `texture_bytes` (bricks are made resident in
//!   id order while they fit; the others are uploaded again every frame,
//!   the steady state of a frame loop): `U / upload_bytes_per_s`; when the
//!   node's textures `T` exceed the host memory `host_bytes`, the
//!   non-resident ones also page in from disk every frame: `U /
//!   disk_bytes_per_s` (a frame sweeps the textures in the same order, and
//!   LRU paging under a cyclic sweep larger than memory evicts every page
//!   before its reuse, so all of `U`, not only `T - host_bytes`, comes from
//!   disk); read-back of the subimage `4 · pixels / readback_bytes_per_s`;
//!   and the host's draw set-up, `textures · per_texture_draw` (a texture
//!   bind and a draw call per texture: one per brick, or one per block of
//!   adaptive sampling, so that many small blocks cost);
//! - without: the software slicer, `samples taken · per_sample`, plus its
//!   per-brick set-up `textures · per_texture_draw` and its texture build
//!   `texture bytes / upload_bytes_per_s` and its subimage `4 · pixels /
//!   readback_bytes_per_s` when those are set (what
//!   `pvrsim calibrate` fits on this host; 0 leaves them out).
//!
//! Blending a received subimage: per pixel `1 / fill_rate + 4 /
//! upload_bytes_per_s` (a textured quad, uploaded), or `per_sample`.

use serde::{Deserialize, Serialize};

use crate::node::CostProfile;

/// A brick's work, as the model sees it.
#[derive(Debug, Clone, Copy, Default)]
pub struct BrickWork {
    /// Texture bytes of the brick.
    pub texture_bytes: u64,
    /// Slice samples inside the brick along covered rays (fragments).
    pub fragments: u64,
    /// Samples the software slicer actually took.
    pub samples_taken: u64,
    /// Pixels of the subimage.
    pub pixels: u64,
    /// Textures drawn (1 for a brick, its blocks with adaptive sampling).
    pub textures: u64,
}

/// Modelled seconds of one node's frame, by part.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct DeviceTime {
    /// Fill (device) or sampling (software).
    pub fill_s: f64,
    /// Texture uploads of non-resident bricks.
    pub upload_s: f64,
    /// Paging the non-resident textures in from disk (host memory exceeded).
    #[serde(default)]
    pub paging_s: f64,
    /// Subimage read-back.
    pub readback_s: f64,
    /// Draw set-up, `textures · per_texture_draw`.
    #[serde(default)]
    pub setup_s: f64,
    /// Textures drawn.
    #[serde(default)]
    pub textures: u64,
    /// Texture bytes that stay resident.
    pub resident_bytes: u64,
    /// Texture bytes uploaded every frame.
    pub uploaded_bytes: u64,
    /// Bricks whose texture alone exceeds the texture memory: a device
    /// cannot draw them as one texture (the paper's "-" in Table 2); the
    /// model still charges them as uploads, so a row with any is not a
    /// frame the paper's hardware could draw.
    #[serde(default)]
    pub oversized_bricks: u64,
}

impl DeviceTime {
    /// The sum of the parts.
    pub fn total(&self) -> f64 {
        self.fill_s + self.upload_s + self.paging_s + self.readback_s + self.setup_s
    }
}

/// Whether `p` can cost a grid frame at all.
pub fn check(p: &CostProfile, name: &str) -> anyhow::Result<()> {
    anyhow::ensure!(
        p.fill_rate > 0.0 || p.per_sample > 0.0,
        "profile {name} has no grid costs (neither fill_rate nor per_sample is set): \
         use --profile radeon9700 or a profile with per_sample"
    );
    Ok(())
}

/// The modelled time of a node rendering `bricks` (in residency order).
pub fn frame_time(bricks: &[BrickWork], p: &CostProfile) -> DeviceTime {
    let mut t = DeviceTime::default();
    if p.fill_rate <= 0.0 {
        t.fill_s = bricks.iter().map(|b| b.samples_taken as f64).sum::<f64>() * p.per_sample;
        t.textures = bricks.iter().map(|b| b.textures).sum();
        t.setup_s = t.textures as f64 * p.per_texture_draw;
        if p.upload_bytes_per_s > 0.0 {
            let bytes: u64 = bricks.iter().map(|b| b.texture_bytes).sum();
            t.upload_s = bytes as f64 / p.upload_bytes_per_s;
        }
        if p.readback_bytes_per_s > 0.0 {
            let px: u64 = bricks.iter().map(|b| b.pixels).sum();
            t.readback_s = 4.0 * px as f64 / p.readback_bytes_per_s;
        }
        return t;
    }
    let mut used = 0u64;
    for b in bricks {
        if p.texture_bytes > 0.0 && b.texture_bytes as f64 > p.texture_bytes {
            t.oversized_bricks += 1;
        }
        t.fill_s += b.fragments as f64 / p.fill_rate;
        t.textures += b.textures;
        t.setup_s += b.textures as f64 * p.per_texture_draw;
        if p.texture_bytes <= 0.0 || (used + b.texture_bytes) as f64 <= p.texture_bytes {
            used += b.texture_bytes;
            t.resident_bytes += b.texture_bytes;
        } else {
            t.uploaded_bytes += b.texture_bytes;
        }
        if p.readback_bytes_per_s > 0.0 {
            t.readback_s += 4.0 * b.pixels as f64 / p.readback_bytes_per_s;
        }
    }
    if p.upload_bytes_per_s > 0.0 {
        t.upload_s = t.uploaded_bytes as f64 / p.upload_bytes_per_s;
    }
    let total = (t.resident_bytes + t.uploaded_bytes) as f64;
    if p.host_bytes > 0.0 && total > p.host_bytes && p.disk_bytes_per_s > 0.0 {
        t.paging_s = t.uploaded_bytes as f64 / p.disk_bytes_per_s;
    }
    t
}

/// Bytes a brick's textures occupy on the device: its stored samples (the
/// renderer's `texture_bytes`, reduced with adaptive sampling) at the
/// profile's `texel_bytes` a sample, or the renderer's own bytes.
pub fn device_bytes(renderer_bytes: u64, bytes_per_sample: u64, p: &CostProfile) -> u64 {
    if p.texel_bytes > 0.0 && bytes_per_sample > 0 {
        (renderer_bytes / bytes_per_sample) * p.texel_bytes as u64
    } else {
        renderer_bytes
    }
}

/// Modelled seconds to blend `pixels` received pixels.
pub fn blend_time(pixels: u64, p: &CostProfile) -> f64 {
    let per = if p.fill_rate > 0.0 {
        1.0 / p.fill_rate
            + if p.upload_bytes_per_s > 0.0 {
                4.0 / p.upload_bytes_per_s
            } else {
                0.0
            }
    } else {
        p.per_sample
    };
    pixels as f64 * per
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bricks_beyond_texture_memory_are_uploaded_every_frame() {
        let p = CostProfile {
            texture_bytes: 100.0,
            fill_rate: 10.0,
            upload_bytes_per_s: 20.0,
            ..Default::default()
        };
        let b = |bytes| BrickWork {
            texture_bytes: bytes,
            fragments: 5,
            samples_taken: 1,
            pixels: 1,
            textures: 3,
        };
        let t = frame_time(&[b(60), b(30), b(40)], &p);
        assert_eq!(t.resident_bytes, 90);
        assert_eq!(t.uploaded_bytes, 40);
        assert!((t.upload_s - 2.0).abs() < 1e-12);
        assert!((t.fill_s - 1.5).abs() < 1e-12);
        // Everything fits: no upload.
        let t = frame_time(&[b(60), b(30)], &p);
        assert_eq!((t.uploaded_bytes, t.upload_s), (0, 0.0));
        // Past host memory the non-resident textures page from disk.
        let host = CostProfile {
            host_bytes: 120.0,
            disk_bytes_per_s: 4.0,
            ..p
        };
        let t = frame_time(&[b(60), b(30), b(40)], &host);
        assert!((t.paging_s - 10.0).abs() < 1e-12, "{t:?}");
        assert!((t.total() - (1.5 + 2.0 + 10.0)).abs() < 1e-12);
        let roomy = CostProfile {
            host_bytes: 130.0,
            ..host
        };
        assert_eq!(frame_time(&[b(60), b(30), b(40)], &roomy).paging_s, 0.0);
        // RGBA8 texels: 4 bytes a stored sample.
        let rgba = CostProfile {
            texel_bytes: 4.0,
            ..p
        };
        assert_eq!(device_bytes(1000, 1, &rgba), 4000);
        assert_eq!(device_bytes(1000, 2, &rgba), 2000);
        assert_eq!(device_bytes(1000, 2, &p), 1000);
        assert_eq!(frame_time(&[b(60), b(101)], &p).oversized_bricks, 1);
        assert_eq!(frame_time(&[b(60), b(100)], &p).oversized_bricks, 0);
        // No device: the software slicer's per-sample cost.
        let cpu = CostProfile {
            per_sample: 2.0,
            ..Default::default()
        };
        assert_eq!(frame_time(&[b(60), b(30)], &cpu).total(), 4.0);
        // ... plus, when fitted, its per-brick set-up and texture build.
        let fitted = CostProfile {
            per_texture_draw: 0.5,
            upload_bytes_per_s: 90.0,
            ..cpu
        };
        let t = frame_time(&[b(60), b(30)], &fitted);
        assert_eq!(t.textures, 6);
        assert!((t.total() - (4.0 + 3.0 + 1.0)).abs() < 1e-12, "{t:?}");
        assert!(check(&CostProfile::default(), "x").is_err());
        // Draw set-up: per texture drawn, on top of the rest.
        let draw = CostProfile {
            per_texture_draw: 0.25,
            ..p
        };
        let t = frame_time(&[b(60), b(30)], &draw);
        assert_eq!(t.textures, 6);
        assert!((t.setup_s - 1.5).abs() < 1e-12);
        assert!((t.total() - frame_time(&[b(60), b(30)], &p).total() - 1.5).abs() < 1e-12);
    }
}
