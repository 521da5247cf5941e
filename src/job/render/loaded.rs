//! A render job whose data stays loaded: the scene read and its mesh or
//! volume loaded once ([`LoadedRender`]), then any number of frames with
//! another camera, transfer function or image size, each exactly the
//! frame `pvrsim render` draws of a scene file holding that camera,
//! transfer function and size (the live viewer's in-process frames).

use crate::job::render::{RenderArgs, RenderOutcome};
use crate::job::validate::Valid;
use crate::render::{RenderInput, VolumeInput};
use crate::scene::{Camera, Scene, TransferFunction};

/// The loaded data of a render job: a mesh or a grid, with the scene whose
/// camera, transfer function and image size the next frame uses.
pub enum LoadedRender {
    /// A tetrahedral mesh (cell projection or the f64 reference).
    Mesh(Box<RenderInput>),
    /// A regular grid (the grid renderers).
    Grid(Box<VolumeInput>),
}

/// What a frame changes against the loaded scene (`None`: keep it).
#[derive(Debug, Clone, Default)]
pub struct ViewChange {
    /// The camera.
    pub camera: Option<Camera>,
    /// The transfer function.
    pub transfer: Option<TransferFunction>,
    /// The image size in pixels.
    pub size: Option<(u32, u32)>,
}

impl<'a> Valid<'a, RenderArgs> {
    /// Reads the scene and loads its mesh or volume once (the checks of
    /// [`Valid::run`](Valid#method.run) made here), for frames drawn by
    /// [`LoadedRender::render`].
    pub fn load(&self) -> anyhow::Result<LoadedRender> {
        let a = self.args();
        let scene = crate::job::load_scene(&a.scene)?;
        Ok(if crate::job::render::grid::is_grid_scene(&scene) {
            LoadedRender::Grid(Box::new(
                crate::job::render::grid::load_checked(a, scene)?.0,
            ))
        } else {
            LoadedRender::Mesh(Box::new(crate::job::render::mesh::load(a, scene, true)?.0))
        })
    }
}

impl LoadedRender {
    /// The scene the next frame draws (with the changes applied so far).
    pub fn scene(&self) -> &Scene {
        match self {
            LoadedRender::Mesh(m) => &m.scene,
            LoadedRender::Grid(g) => &g.scene,
        }
    }

    /// True for a regular grid.
    pub fn is_grid(&self) -> bool {
        matches!(self, LoadedRender::Grid(_))
    }

    /// Applies a change to the scene the next frames draw. The camera is
    /// checked as a scene file's is (a NaN, eye = target, up along the
    /// view: refused, naming the key); the transfer function must come from
    /// [`crate::scene::transfer_from_rows`] (which checks it).
    pub fn apply(&mut self, change: &ViewChange) -> anyhow::Result<()> {
        if let Some(c) = &change.camera {
            c.check()
                .map_err(|(k, m)| anyhow::anyhow!("camera: {k}: {m}"))?;
        }
        if let Some((w, h)) = change.size {
            anyhow::ensure!(
                (1..=65536).contains(&w) && (1..=65536).contains(&h),
                "image size {w}x{h}: each side must be between 1 and 65536 pixels"
            );
        }
        let scene = match self {
            LoadedRender::Mesh(m) => &mut m.scene,
            LoadedRender::Grid(g) => &mut g.scene,
        };
        if let Some(c) = change.camera {
            scene.camera = c;
        }
        if let Some(t) = &change.transfer {
            scene.transfer = t.clone();
        }
        if let Some((w, h)) = change.size {
            scene.image.width = w;
            scene.image.height = h;
        }
        Ok(())
    }

    /// Draws the loaded scene with the options `a` (those `load` was given,
    /// or others of the same data kind: another renderer, ERT threshold),
    /// writing nothing and printing nothing. The options are validated
    /// here (a frontend may have changed them since `load`).
    pub fn render(&self, a: &RenderArgs) -> anyhow::Result<RenderOutcome> {
        match self {
            LoadedRender::Mesh(m) => {
                crate::job::render::mesh::render(&Valid::new(a)?, m, 0.0, true)
            }
            LoadedRender::Grid(g) => crate::job::render::grid::render(a, g, 0.0, true),
        }
    }

    /// The field's histogram on the transfer function's `[0, 1]` scale:
    /// `bins` counts of the vertices (mesh) or voxels (grid) whose
    /// normalised scalar falls in each bin (values outside `[0, 1]` are
    /// counted in the end bins, as the transfer function clamps them).
    pub fn histogram(&self, bins: usize) -> Vec<u64> {
        let bins = bins.max(1);
        let mut h = vec![0u64; bins];
        let mut add = |s: f64| {
            if s.is_finite() {
                let b = (s.clamp(0.0, 1.0) * bins as f64) as usize;
                h[b.min(bins - 1)] += 1;
            }
        };
        match self {
            LoadedRender::Mesh(m) => m.s_norm.iter().for_each(|&s| add(s)),
            LoadedRender::Grid(g) => {
                let v = &g.volume.voxels;
                (0..v.len()).for_each(|i| add(g.normalise(v.get_f32(i) as f64)));
            }
        }
        h
    }

    /// A coarse stand-in of a loaded mesh of at most about `max_cells`
    /// tetrahedra ([`RenderInput::coarse`](crate::render::RenderInput::coarse):
    /// the field resampled on a lattice), with the same scene: frames drawn
    /// while the user moves the view. `None` for a grid or a mesh that is
    /// already that small.
    pub fn coarse(&self, max_cells: usize) -> Option<LoadedRender> {
        match self {
            LoadedRender::Mesh(m) => m.coarse(max_cells).map(|c| LoadedRender::Mesh(Box::new(c))),
            LoadedRender::Grid(_) => None,
        }
    }

    /// The raw scalar range that maps to the transfer function's `[0, 1]`.
    pub fn range(&self) -> [f64; 2] {
        match self {
            LoadedRender::Mesh(m) => m.range,
            LoadedRender::Grid(g) => g.range,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame of a loaded scene with a changed camera and size equals
    /// `pvrsim render` of a scene file holding that camera and size.
    #[test]
    fn changed_frame_equals_a_fresh_render_of_the_changed_scene() {
        let path = std::path::Path::new("tests/data/aorta-small-view-b.toml");
        let a = RenderArgs::new(path);
        let mut loaded = Valid::new(&a).unwrap().load().unwrap();
        let mut cam = loaded.scene().camera;
        cam.eye = [40.0, 30.0, 200.0];
        loaded
            .apply(&ViewChange {
                camera: Some(cam),
                transfer: None,
                size: Some((64, 48)),
            })
            .unwrap();
        let frame = loaded.render(&a).unwrap().image;
        let dir = tempfile::tempdir().unwrap();
        let data = std::fs::canonicalize("tests/data/aorta-small.vtk").unwrap();
        let toml = loaded.scene().to_toml(&data.to_string_lossy());
        let p = dir.path().join("s.toml");
        std::fs::write(&p, toml).unwrap();
        let fresh = RenderArgs::new(&p).run().unwrap().image;
        assert_eq!((frame.width, frame.height), (64, 48));
        assert_eq!(frame.png_bytes().unwrap(), fresh.png_bytes().unwrap());
        let unchanged = RenderArgs::new(path).run().unwrap().image;
        assert_ne!(frame.pixels.len(), unchanged.pixels.len());
    }

    #[test]
    fn a_nan_camera_is_refused_and_the_scene_kept() {
        let a = RenderArgs::new("tests/data/aorta-small-view-b.toml");
        let mut loaded = Valid::new(&a).unwrap().load().unwrap();
        let before = loaded.scene().camera;
        let mut cam = before;
        cam.eye[0] = f64::NAN;
        let e = loaded
            .apply(&ViewChange {
                camera: Some(cam),
                ..Default::default()
            })
            .unwrap_err();
        assert!(e.to_string().contains("camera"), "{e}");
        assert_eq!(loaded.scene().camera, before);
        let h = loaded.histogram(16);
        assert_eq!(h.iter().sum::<u64>(), 5326);
    }
}
