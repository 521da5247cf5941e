//! Where the viewer's frames come from, behind one trait ([`Backend`]):
//!
//! - [`Local`]: in this process, exactly as `pvrsim render` draws (the
//!   job layer's [`LoadedRender`]: the data loaded once, each frame with
//!   the new camera, transfer function and size), so `/frame.png` equals
//!   `pvrsim render` of `/scene.toml` bit for bit.
//! - `Cluster` (`view::cluster`, `--nodes N`): `pvrsim cluster`'s frames of the current
//!   view on N nodes (threads, worker processes or TCP workers) on the
//!   job layer's persistent [`Session`](crate::job::Session) (nodes set up and data placed
//!   once), with the per-node figures of each frame's report.

use crate::image::Image;
use std::collections::HashMap;
use std::path::Path;

use crate::job::render::loaded::DataStates;
use crate::job::render::{RenderArgs, RendererKind};
use crate::job::{LoadedRender, Valid, ViewChange};
use crate::scene::Scene;

use super::pace::Level;

/// Bins of the histogram the page draws under the transfer function.
pub const HISTOGRAM_BINS: usize = 128;

/// Cells of the coarse stand-in of a mesh drawn while the user moves the
/// view (`--interactive-scale auto`; meshes with more cells only): small
/// enough that cell projection draws it in a few tens of ms at 256x256 on
/// one core (docs/viewer.md).
pub const COARSE_CELLS: usize = 20_000;

/// Meshes of more cells than this get a coarse stand-in (smaller ones are
/// drawn at 1/2 to 1/8 of the image size in a few tens of ms).
pub const COARSE_ABOVE: usize = 4 * COARSE_CELLS;

/// What the page is told once, when it connects.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Info {
    /// The scene file's name.
    pub scene_name: String,
    /// The field rendered.
    pub field: String,
    /// The data's point fields (a grid: its one field).
    pub fields: Vec<String>,
    /// The time steps' mesh file names (the scene's first; `--series`).
    pub steps: Vec<String>,
    /// Their absolute paths (a recorded series names them).
    pub step_paths: Vec<String>,
    /// The time step shown.
    pub step: usize,
    /// Its raw range (the transfer function's `[0, 1]`).
    pub range: [f64; 2],
    /// Counts over [`HISTOGRAM_BINS`] bins of the normalised field.
    pub histogram: Vec<u64>,
    /// The renderers the page may choose (by `--renderer` name).
    pub renderers: Vec<String>,
    /// The renderer in use.
    pub renderer: String,
    /// The ERT threshold in use.
    pub ert: f64,
    /// Cluster nodes (0: in this process).
    pub nodes: usize,
    /// The transport's name (`in-process` without --nodes).
    pub transport: String,
}

/// A frame as a backend drew it.
pub struct Rendered {
    /// The image.
    pub image: Image,
    /// Seconds the backend took (rendering, and for a cluster the job).
    pub render_s: f64,
    /// Per node (cluster only): name -> value of the report's figures the
    /// page draws as bars.
    pub nodes: Vec<serde_json::Value>,
    /// Cells drawn (of the coarse stand-in when the level asked for it).
    pub cells: usize,
}

/// A source of frames for the viewer.
pub trait Backend: Send {
    /// The scene the next full frame draws (camera, transfer function and
    /// image size as changed so far).
    fn scene(&self) -> &Scene;
    /// What the page is told when it connects.
    fn info(&self) -> Info;
    /// Applies a camera/transfer change to the scene of the next frames.
    fn apply(&mut self, change: &ViewChange) -> anyhow::Result<()>;
    /// Switches to time step `step` and/or the field `field` (the
    /// camera, transfer function and size kept); the histogram and range
    /// of [`Backend::info`] follow.
    fn select(&mut self, step: Option<usize>, field: Option<&str>) -> anyhow::Result<()>;
    /// Changes the ERT threshold and/or the renderer.
    fn set_options(
        &mut self,
        ert: Option<f64>,
        renderer: Option<RendererKind>,
    ) -> anyhow::Result<()>;
    /// Draws the scene at `1/level.divisor` of its size along each axis,
    /// from the coarse stand-in of the mesh when `level.coarse` (and the
    /// backend has one).
    fn frame(&mut self, level: Level) -> anyhow::Result<Rendered>;
    /// Whether a coarse stand-in of the data exists (a mesh of more than
    /// [`COARSE_ABOVE`] cells, with `--interactive-scale auto`).
    fn has_coarse(&self) -> bool;
    /// The `pvrsim render` / `pvrsim cluster` options that, with the scene
    /// TOML `/scene.toml` serves, reproduce the full frame.
    fn command_options(&self) -> String;
}

/// The time steps' names the page lists (file names).
pub fn step_names(states: &DataStates) -> Vec<String> {
    states
        .steps
        .iter()
        .map(|p| {
            p.file_name().map_or_else(
                || p.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
        })
        .collect()
}

/// The time steps' absolute paths.
pub fn step_paths(states: &DataStates) -> Vec<String> {
    states
        .steps
        .iter()
        .map(|p| {
            std::fs::canonicalize(p)
                .unwrap_or_else(|_| p.clone())
                .display()
                .to_string()
        })
        .collect()
}

/// The (time step, field) `step`/`field` ask for, the others kept from
/// `now`: the index of its data state, checked.
pub fn chosen(
    states: &DataStates,
    now: (usize, &str),
    step: Option<usize>,
    field: Option<&str>,
) -> anyhow::Result<(usize, String, usize)> {
    let step = step.unwrap_or(now.0);
    let field = field.unwrap_or(now.1).to_string();
    let state = states.state(step, &field).map_err(anyhow::Error::msg)?;
    Ok((step, field, state))
}

/// The reduced size of an interactive frame (each side at least 1).
pub fn reduced(w: u32, h: u32, divisor: u32) -> (u32, u32) {
    let d = divisor.max(1);
    (w.div_ceil(d).max(1), h.div_ceil(d).max(1))
}

/// The renderer names for a mesh or a grid.
pub(super) fn renderer_names(grid: bool) -> Vec<String> {
    let all: &[RendererKind] = if grid {
        &[
            RendererKind::ShearWarp,
            RendererKind::Slice3d,
            RendererKind::Slice2d,
            RendererKind::Splat,
            RendererKind::Reference,
        ]
    } else {
        &[RendererKind::Cell, RendererKind::Reference]
    };
    all.iter().map(|k| renderer_name(Some(*k))).collect()
}

/// `--renderer`'s spelling of a renderer (`default` for none).
pub fn renderer_name(k: Option<RendererKind>) -> String {
    k.and_then(|k| clap::ValueEnum::to_possible_value(&k))
        .map_or("default".into(), |v| v.get_name().to_string())
}

/// In this process, as `pvrsim render`.
pub struct Local {
    args: RenderArgs,
    loaded: LoadedRender,
    states: DataStates,
    /// The time step, field and data state shown.
    step: usize,
    field: String,
    state: usize,
    /// Whether large meshes get a coarse stand-in (`auto`), and the
    /// stand-ins built so far, per data state.
    coarse_wanted: bool,
    coarse: HashMap<usize, Option<LoadedRender>>,
    histogram: Vec<u64>,
}

impl Local {
    /// Validates the render options once and loads the scene's data with
    /// every field and the time steps of `series` (and builds the coarse
    /// stand-in of a large mesh when `coarse`).
    pub fn open(args: &RenderArgs, series: Option<&Path>, coarse: bool) -> anyhow::Result<Local> {
        let job = Valid::new(args)?;
        job.print_warnings();
        let (loaded, states) = job.load_states(series)?;
        let histogram = loaded.histogram(HISTOGRAM_BINS);
        let field = loaded.scene().data.field.clone();
        let mut l = Local {
            args: args.clone(),
            coarse: HashMap::new(),
            coarse_wanted: coarse,
            loaded,
            step: 0,
            state: 0,
            field,
            states,
            histogram,
        };
        l.build_coarse();
        Ok(l)
    }

    /// The coarse stand-in of the state shown, built once per state.
    fn build_coarse(&mut self) {
        if self.coarse_wanted && !self.coarse.contains_key(&self.state) {
            let c = coarse_of(&self.loaded);
            self.coarse.insert(self.state, c);
        }
    }
}

/// The coarse stand-in of a mesh of more than [`COARSE_ABOVE`] cells.
pub(super) fn coarse_of(loaded: &LoadedRender) -> Option<LoadedRender> {
    match loaded {
        LoadedRender::Mesh(m) if m.mesh.tets.len() > COARSE_ABOVE => loaded.coarse(COARSE_CELLS),
        _ => None,
    }
}

/// A frame of the coarse stand-in `coarse` of a scene: its camera and
/// transfer function, at `size`, drawn with the options `a` (lists not
/// kept canonical: the frame is a stand-in, not `pvrsim render`'s).
pub(super) fn coarse_frame(
    coarse: &mut LoadedRender,
    scene: &Scene,
    size: (u32, u32),
    a: &RenderArgs,
) -> anyhow::Result<Rendered> {
    let t = std::time::Instant::now();
    coarse.apply(&ViewChange {
        camera: Some(scene.camera),
        transfer: Some(scene.transfer.clone()),
        size: Some(size),
    })?;
    let mut a = a.clone();
    a.canonical = false;
    let image = coarse.render(&a)?.image;
    let cells = match coarse {
        LoadedRender::Mesh(m) => m.mesh.tets.len(),
        LoadedRender::Grid(_) => 0,
    };
    Ok(Rendered {
        image,
        render_s: t.elapsed().as_secs_f64(),
        nodes: Vec::new(),
        cells,
    })
}

impl Backend for Local {
    fn scene(&self) -> &Scene {
        self.loaded.scene()
    }

    fn info(&self) -> Info {
        let s = self.scene();
        Info {
            scene_name: self.args.scene.display().to_string(),
            field: s.data.field.clone(),
            fields: self.states.fields.clone(),
            steps: step_names(&self.states),
            step_paths: step_paths(&self.states),
            step: self.step,
            range: self.loaded.range(),
            histogram: self.histogram.clone(),
            renderers: renderer_names(self.loaded.is_grid()),
            renderer: renderer_name(self.args.renderer),
            ert: f64::from(self.args.ert.threshold),
            nodes: 0,
            transport: "in-process".into(),
        }
    }

    fn apply(&mut self, change: &ViewChange) -> anyhow::Result<()> {
        self.loaded.apply(change)
    }

    fn select(&mut self, step: Option<usize>, field: Option<&str>) -> anyhow::Result<()> {
        let (step, field, state) = chosen(&self.states, (self.step, &self.field), step, field)?;
        if state != self.state {
            if let Some(input) = self.states.inputs.get(state) {
                self.loaded.select(input);
            }
            self.histogram = self.loaded.histogram(HISTOGRAM_BINS);
        }
        (self.step, self.field, self.state) = (step, field, state);
        self.build_coarse();
        Ok(())
    }

    fn set_options(
        &mut self,
        ert: Option<f64>,
        renderer: Option<RendererKind>,
    ) -> anyhow::Result<()> {
        let mut a = self.args.clone();
        if let Some(t) = ert {
            a.ert.threshold = t as f32;
        }
        if renderer.is_some() {
            a.renderer = renderer;
        }
        let grid = self.loaded.is_grid();
        if let Some(k) = a.renderer {
            anyhow::ensure!(
                renderer_names(grid).contains(&renderer_name(Some(k))),
                "renderer {} does not draw this scene's {} (use {})",
                renderer_name(Some(k)),
                if grid {
                    "regular grid"
                } else {
                    "tetrahedral mesh"
                },
                renderer_names(grid).join(", ")
            );
        }
        Valid::new(&a)?;
        self.args = a;
        Ok(())
    }

    fn has_coarse(&self) -> bool {
        self.coarse.get(&self.state).is_some_and(Option::is_some)
    }

    fn frame(&mut self, level: Level) -> anyhow::Result<Rendered> {
        let t = std::time::Instant::now();
        let divisor = level.divisor;
        let full = (self.scene().image.width, self.scene().image.height);
        let coarse = self.coarse.get_mut(&self.state).and_then(Option::as_mut);
        if let (true, Some(c)) = (level.coarse, coarse) {
            let size = reduced(full.0, full.1, divisor);
            return coarse_frame(c, self.loaded.scene(), size, &self.args);
        }
        let image = if divisor <= 1 {
            self.loaded.render(&self.args)?.image
        } else {
            let small = reduced(full.0, full.1, divisor);
            self.loaded.apply(&ViewChange {
                size: Some(small),
                ..Default::default()
            })?;
            let out = self.loaded.render(&self.args);
            self.loaded.apply(&ViewChange {
                size: Some(full),
                ..Default::default()
            })?;
            out?.image
        };
        Ok(Rendered {
            image,
            render_s: t.elapsed().as_secs_f64(),
            nodes: Vec::new(),
            cells: match &self.loaded {
                LoadedRender::Mesh(m) => m.mesh.tets.len(),
                LoadedRender::Grid(g) => g.volume.voxels.len() as usize,
            },
        })
    }

    fn command_options(&self) -> String {
        let mut s = format!("--ert {}", self.args.ert.threshold);
        if let Some(k) = self.args.renderer {
            s += &format!(" --renderer {}", renderer_name(Some(k)));
        }
        if self.args.canonical {
            s += " --canonical";
        }
        s
    }
}
