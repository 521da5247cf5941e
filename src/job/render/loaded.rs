//! A render job whose data stays loaded: the scene read and its mesh or
//! volume loaded once ([`LoadedRender`]), then any number of frames with
//! another camera, transfer function or image size, each exactly the
//! frame `pvrsim render` draws of a scene file holding that camera,
//! transfer function and size (the live viewer's in-process frames).

use crate::job::render::{RenderArgs, RenderOutcome};
use crate::job::validate::Valid;
use crate::render::{RenderInput, VolumeInput};
use std::path::{Path, PathBuf};

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

/// Every data state a live view can switch between: the time steps'
/// meshes (the scene's first, then those a series file names) and the
/// point fields of the data; each (time step, field) pair is one input,
/// built as a series' frame naming that mesh and field
/// ([`crate::job::series::steps::data_states`]: the same mesh numbering,
/// topology check and scene, so that a cluster session holds the same
/// inputs).
pub struct DataStates {
    /// The time steps' mesh files (the scene's data first).
    pub steps: Vec<PathBuf>,
    /// The point fields of the data (a grid: its one field).
    pub fields: Vec<String>,
    /// One input per distinct (time step, field) of a mesh scene (empty
    /// for a grid); the scene's own first.
    pub inputs: Vec<RenderInput>,
    /// The input of (step `s`, field `f`) at `s * fields.len() + f`.
    table: Vec<usize>,
}

impl DataStates {
    /// The index in [`DataStates::inputs`] of time step `step` and field
    /// `field`; a refusal the page shows for a step or field that does not
    /// exist.
    pub fn state(&self, step: usize, field: &str) -> Result<usize, String> {
        let f = self.field_index(field)?;
        if step >= self.steps.len() {
            return Err(no_such_step(step, self.steps.len()));
        }
        Ok(self
            .table
            .get(step * self.fields.len() + f)
            .copied()
            .unwrap_or(0))
    }

    /// The position of `field` among [`DataStates::fields`].
    pub fn field_index(&self, field: &str) -> Result<usize, String> {
        self.fields
            .iter()
            .position(|f| f == field)
            .ok_or_else(|| unknown_field(field, &self.fields))
    }
}

/// The refusal of a field the data does not have.
pub fn unknown_field(field: &str, fields: &[String]) -> String {
    format!(
        "unknown field \"{field}\": the data has {}",
        fields
            .iter()
            .map(|f| format!("\"{f}\""))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// The refusal of time step `step` of `steps`.
pub fn no_such_step(step: usize, steps: usize) -> String {
    format!(
        "time step {step} does not exist: the viewer holds {steps} (0..{}){}",
        steps.saturating_sub(1),
        if steps == 1 {
            "; pvrsim view --series FILE.toml loads a series' time steps"
        } else {
            ""
        }
    )
}

/// The time steps of a series file over `scene`: the scene's mesh, then
/// every other mesh its frames name, in order, each once (its cameras,
/// transfer functions and fields are not replayed: the page chooses).
pub fn series_steps(series: &Path, scene: &Scene) -> anyhow::Result<Vec<PathBuf>> {
    let specs = crate::scene::series::load(series, scene)?;
    let mut steps = vec![scene.data.path.clone()];
    for f in specs {
        if !steps.contains(&f.mesh) {
            steps.push(f.mesh);
        }
    }
    Ok(steps)
}

impl<'a> Valid<'a, RenderArgs> {
    /// [`Valid::load`] with every data state a live view can switch
    /// between: the scene's fields, and the time steps of `series` (a
    /// series file; mesh scenes only). The loaded render draws the scene's
    /// own state; [`LoadedRender::select`] switches.
    pub fn load_states(&self, series: Option<&Path>) -> anyhow::Result<(LoadedRender, DataStates)> {
        let a = self.args();
        let scene = crate::job::load_scene(&a.scene)?;
        if crate::job::render::grid::is_grid_scene(&scene) {
            if let Some(p) = series {
                anyhow::bail!(
                    "--series {}: time steps are a mesh scene's; {} is a regular grid",
                    p.display(),
                    a.scene.display()
                );
            }
            let states = DataStates {
                steps: vec![scene.data.path.clone()],
                fields: vec![scene.data.field.clone()],
                inputs: Vec::new(),
                table: vec![0],
            };
            let grid = crate::job::render::grid::load_checked(a, scene)?.0;
            return Ok((LoadedRender::Grid(Box::new(grid)), states));
        }
        let steps = match series {
            Some(p) => series_steps(p, &scene)?,
            None => vec![scene.data.path.clone()],
        };
        let (mut input, _) = crate::job::render::mesh::load_keeping_fields(a, scene, true)?;
        let fields: Vec<String> = input.mesh.fields.iter().map(|f| f.name.clone()).collect();
        let specs = steps
            .iter()
            .flat_map(|m| {
                fields.iter().map(|f| crate::scene::series::FrameSpec {
                    camera: input.scene.camera,
                    transfer: input.scene.transfer.clone(),
                    field: f.clone(),
                    mesh: m.clone(),
                })
            })
            .collect();
        let like = input.renumbering.take();
        let origin = series.unwrap_or(&a.scene).to_path_buf();
        let (inputs, per_spec) =
            crate::job::series::steps::data_states(specs, input, like.as_deref(), &origin)?;
        let table = per_spec.iter().map(|s| s.data).collect();
        let loaded = LoadedRender::Mesh(Box::new(inputs[0].clone()));
        Ok((
            loaded,
            DataStates {
                steps,
                fields,
                inputs,
                table,
            },
        ))
    }
}

impl LoadedRender {
    /// Switches a loaded mesh to `input` (a state of [`DataStates`]),
    /// keeping the camera, transfer function and image size of the frames
    /// so far.
    pub fn select(&mut self, input: &RenderInput) {
        if let LoadedRender::Mesh(m) = self {
            let mut next = input.clone();
            next.scene.camera = m.scene.camera;
            next.scene.transfer = m.scene.transfer.clone();
            next.scene.image = m.scene.image;
            **m = next;
        }
    }

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
