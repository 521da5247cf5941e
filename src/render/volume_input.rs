//! What every renderer of a regular grid is given: the grid twin of
//! [`RenderInput`](super::RenderInput).
//!
//! The voxels stay in their own type (a 512^3 u8 volume stays 128 MiB); the
//! normalisation `s_norm = (s - r0) / (r1 - r0)` of the scene contract is not
//! applied to a copy but carried as the range `[r0, r1]`, which each renderer
//! folds into its own lookup (f64 in the reference, f32 tables in the slicers).

use std::sync::Arc;

use crate::data::Volume;
use crate::error::{Error, Result};
use crate::scene::Scene;

/// A scene with its volume loaded and the scalar range that maps to the
/// transfer function's `[0, 1]`.
#[derive(Debug, Clone)]
pub struct VolumeInput {
    /// The scene.
    pub scene: Scene,
    /// The volume.
    pub volume: Arc<Volume>,
    /// `[r0, r1]`: the scene's `data.range`, or the volume's value range.
    /// A constant volume without an explicit range gets `[v, v + 1]`, which
    /// maps every voxel to `s_norm = 0` (as the mesh input does).
    pub range: [f64; 2],
}

impl VolumeInput {
    /// Pairs a scene with a volume. Fails when the volume's box is flat
    /// along an axis (a single sample): the trilinear field then has no
    /// volume and every renderer would silently draw nothing.
    pub fn new(scene: Scene, volume: Arc<Volume>) -> Result<VolumeInput> {
        if let Some(a) = (0..3).find(|&a| volume.dims[a] < 2) {
            return Err(Error::Invalid(format!(
                "{}: the volume has {} sample(s) along axis {a}: a grid needs at least 2 \
                 along every axis to enclose a volume",
                scene.data.path.display(),
                volume.dims[a]
            )));
        }
        let range = match scene.data.range {
            Some(r) => r,
            None => {
                let [lo, hi] = volume.value_range();
                if hi > lo {
                    [lo, hi]
                } else {
                    [lo, lo + 1.0]
                }
            }
        };
        Ok(VolumeInput {
            scene,
            volume,
            range,
        })
    }

    /// `s_norm` of a raw scalar (not clamped: the transfer function clamps).
    #[inline]
    pub fn normalise(&self, s: f64) -> f64 {
        (s - self.range[0]) / (self.range[1] - self.range[0])
    }

    /// The same input with the image size replaced (camera unchanged).
    pub fn with_size(mut self, width: u32, height: u32) -> VolumeInput {
        self.scene.image.width = width;
        self.scene.image.height = height;
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Voxels;
    use std::path::Path;

    fn scene() -> Scene {
        Scene::parse(
            r#"
[data]
path = "v.nrrd"
field = "s"
[camera]
eye = [0, 0, -10]
target = [0, 0, 0]
up = [0, 1, 0]
projection = "orthographic"
height = 4
[image]
width = 4
height = 4
[transfer]
unit_distance = 1
points = [[0, 1, 1, 1, 0], [1, 1, 1, 1, 1]]
"#,
            Path::new("s.toml"),
        )
        .unwrap()
    }

    #[test]
    fn range_defaults_to_the_volume_and_flat_volumes_are_refused() {
        let v = Volume::new(
            Path::new("v"),
            [2, 2, 2],
            [1.0; 3],
            [0.0; 3],
            "s",
            Voxels::U8(vec![10, 20, 30, 40, 50, 60, 70, 90]),
        )
        .unwrap();
        let inp = VolumeInput::new(scene(), Arc::new(v)).unwrap();
        assert_eq!(inp.range, [10.0, 90.0]);
        assert!((inp.normalise(50.0) - 0.5).abs() < 1e-12);
        let flat = Volume::new(
            Path::new("v"),
            [2, 1, 2],
            [1.0; 3],
            [0.0; 3],
            "s",
            Voxels::U8(vec![0; 4]),
        )
        .unwrap();
        let e = VolumeInput::new(scene(), Arc::new(flat)).unwrap_err();
        assert!(e.to_string().contains("axis 1"), "{e}");
    }
}
