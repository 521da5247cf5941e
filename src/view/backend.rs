//! Where the viewer's frames come from, behind one trait ([`Backend`]):
//!
//! - [`Local`]: in this process, exactly as `pvrsim render` draws (the
//!   job layer's [`LoadedRender`]: the data loaded once, each frame with
//!   the new camera, transfer function and size), so `/frame.png` equals
//!   `pvrsim render` of `/scene.toml` bit for bit.
//! - [`Cluster`] (`--nodes N`): `pvrsim cluster`'s frames of the current
//!   view on N nodes (threads, worker processes or TCP workers) on the
//!   job layer's persistent [`Session`] (nodes set up and data placed
//!   once), with the per-node figures of each frame's report.

use crate::image::Image;
use crate::job::args::transport::TransportKind;
use crate::job::render::{RenderArgs, RendererKind};
use crate::job::{ClusterJob, FrameRequest, LoadedRender, Session, Valid, ViewChange};
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

/// The backend `args` asks for, with the scene and data loaded.
pub fn open(args: &super::ViewArgs) -> anyhow::Result<Box<dyn Backend>> {
    let coarse = args.interactive_scale == super::InteractiveScale::Auto;
    Ok(match args.nodes {
        None => Box::new(Local::open(&args.render, coarse)?),
        Some(n) => Box::new(Cluster::open(args, n)?),
    })
}

/// The reduced size of an interactive frame (each side at least 1).
pub fn reduced(w: u32, h: u32, divisor: u32) -> (u32, u32) {
    let d = divisor.max(1);
    (w.div_ceil(d).max(1), h.div_ceil(d).max(1))
}

/// The renderer names for a mesh or a grid.
fn renderer_names(grid: bool) -> Vec<String> {
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
    coarse: Option<LoadedRender>,
    histogram: Vec<u64>,
}

impl Local {
    /// Validates the render options once and loads the scene's data (and
    /// builds the coarse stand-in of a large mesh when `coarse`).
    pub fn open(args: &RenderArgs, coarse: bool) -> anyhow::Result<Local> {
        let job = Valid::new(args)?;
        job.print_warnings();
        let loaded = job.load()?;
        let histogram = loaded.histogram(HISTOGRAM_BINS);
        Ok(Local {
            args: args.clone(),
            coarse: coarse.then(|| coarse_of(&loaded)).flatten(),
            loaded,
            histogram,
        })
    }
}

/// The coarse stand-in of a mesh of more than [`COARSE_ABOVE`] cells.
fn coarse_of(loaded: &LoadedRender) -> Option<LoadedRender> {
    match loaded {
        LoadedRender::Mesh(m) if m.mesh.tets.len() > COARSE_ABOVE => loaded.coarse(COARSE_CELLS),
        _ => None,
    }
}

/// A frame of the coarse stand-in `coarse` of a scene: its camera and
/// transfer function, at `size`, drawn with the options `a` (lists not
/// kept canonical: the frame is a stand-in, not `pvrsim render`'s).
fn coarse_frame(
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
        self.coarse.is_some()
    }

    fn frame(&mut self, level: Level) -> anyhow::Result<Rendered> {
        let t = std::time::Instant::now();
        let divisor = level.divisor;
        let full = (self.scene().image.width, self.scene().image.height);
        if let (true, Some(c)) = (level.coarse, self.coarse.as_mut()) {
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

/// On a cluster: frames on a persistent session ([`Session`]: the nodes
/// set up and the data placed once, each frame carrying the camera,
/// transfer function and size).
pub struct Cluster {
    job: ClusterJob,
    session: Option<Session>,
    /// The coarse stand-in of the mesh, drawn in this process while the
    /// user moves the view (`--interactive-scale auto`; as ParaView draws
    /// its level of detail on the client), with the options it is drawn
    /// with.
    coarse: Option<(LoadedRender, RenderArgs)>,
    cells: usize,
    scene: Scene,
    histogram: Vec<u64>,
    range: [f64; 2],
    transport: String,
}

impl Cluster {
    /// The cluster job of `args` (its scene, `--nodes`, `--transport`,
    /// `--ert`, `--canonical`, `--width`/`--height`) validated and its
    /// session opened; the data also read here once for the histogram.
    pub fn open(args: &super::ViewArgs, nodes: usize) -> anyhow::Result<Cluster> {
        let r = &args.render;
        let transport = args.transport.unwrap_or(TransportKind::Threads);
        let mut job = ClusterJob::new(&r.scene);
        job.nodes = nodes;
        job.net.transport = Some(transport);
        job.net.worker_program = args.worker_program.clone();
        job.ert.threshold = r.ert.threshold;
        job.canonical = r.canonical;
        job.width = r.width;
        job.height = r.height;
        anyhow::ensure!(
            r.renderer.is_none() || r.renderer == Some(RendererKind::Cell),
            "--renderer with --nodes: a cluster draws meshes by cell projection; leave --renderer out"
        );
        let loaded = Valid::new(r)?.load()?;
        anyhow::ensure!(
            !loaded.is_grid(),
            "{}: `pvrsim view --nodes` serves mesh scenes (a cluster session holds a mesh); view \
             a grid without --nodes",
            r.scene.display()
        );
        let histogram = loaded.histogram(HISTOGRAM_BINS);
        let range = loaded.range();
        let cells = match &loaded {
            LoadedRender::Mesh(m) => m.mesh.tets.len(),
            LoadedRender::Grid(_) => 0,
        };
        let coarse = (args.interactive_scale == super::InteractiveScale::Auto)
            .then(|| coarse_of(&loaded))
            .flatten()
            .map(|c| {
                let mut a = r.clone();
                a.renderer = Some(RendererKind::Cell);
                (c, a)
            });
        drop(loaded);
        let session = Session::open(&job).map_err(|e| anyhow::anyhow!("{e}"))?;
        let scene = session.scene().clone();
        Ok(Cluster {
            job,
            session: Some(session),
            coarse,
            cells,
            scene,
            histogram,
            range,
            transport: transport.name().to_string(),
        })
    }

    fn session(&mut self) -> anyhow::Result<&mut Session> {
        if self.session.is_none() {
            self.session = Some(Session::open(&self.job).map_err(|e| anyhow::anyhow!("{e}"))?);
        }
        Ok(self.session.as_mut().expect("opened above"))
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        if let Some(s) = self.session.take() {
            if let Err(e) = s.close() {
                crate::job::output::warn(format!("closing the cluster session: {e}"));
            }
        }
    }
}

impl Backend for Cluster {
    fn scene(&self) -> &Scene {
        &self.scene
    }

    fn info(&self) -> Info {
        Info {
            scene_name: self.job.scene.display().to_string(),
            field: self.scene.data.field.clone(),
            range: self.range,
            histogram: self.histogram.clone(),
            renderers: vec!["cell".into()],
            renderer: "cell".into(),
            ert: f64::from(self.job.ert.threshold),
            nodes: self.job.nodes,
            transport: self.transport.clone(),
        }
    }

    fn apply(&mut self, change: &ViewChange) -> anyhow::Result<()> {
        if let Some(c) = &change.camera {
            c.check()
                .map_err(|(k, m)| anyhow::anyhow!("camera: {k}: {m}"))?;
            self.scene.camera = *c;
        }
        if let Some(t) = &change.transfer {
            self.scene.transfer = t.clone();
        }
        if let Some((w, h)) = change.size {
            (self.scene.image.width, self.scene.image.height) = (w, h);
        }
        Ok(())
    }

    /// A new ERT threshold reopens the session (the nodes' options are
    /// set when it opens).
    fn set_options(
        &mut self,
        ert: Option<f64>,
        renderer: Option<RendererKind>,
    ) -> anyhow::Result<()> {
        anyhow::ensure!(
            renderer.is_none() || renderer == Some(RendererKind::Cell),
            "the renderer of a cluster is cell projection"
        );
        if let Some(t) = ert {
            let mut j = self.job.clone();
            j.ert.threshold = t as f32;
            j.check().map_err(|e| anyhow::anyhow!("{e}"))?;
            if let Some(s) = self.session.take() {
                s.close().map_err(|e| anyhow::anyhow!("{e}"))?;
            }
            self.job = j;
            if let Some((_, a)) = self.coarse.as_mut() {
                a.ert.threshold = t as f32;
            }
        }
        Ok(())
    }

    fn has_coarse(&self) -> bool {
        self.coarse.is_some()
    }

    fn frame(&mut self, level: Level) -> anyhow::Result<Rendered> {
        let t = std::time::Instant::now();
        let divisor = level.divisor;
        let full = (self.scene.image.width, self.scene.image.height);
        if let (true, Some((c, a))) = (level.coarse, self.coarse.as_mut()) {
            return coarse_frame(c, &self.scene, reduced(full.0, full.1, divisor), a);
        }
        let req = FrameRequest {
            camera: Some(self.scene.camera),
            transfer: Some(self.scene.transfer.clone()),
            step: None,
            size: Some(reduced(full.0, full.1, divisor)),
        };
        let out = self
            .session()?
            .frame(&req)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let report = serde_json::to_value(&out.report)?;
        let nodes = report["nodes"].as_array().cloned().unwrap_or_default();
        Ok(Rendered {
            image: out.image,
            render_s: t.elapsed().as_secs_f64(),
            nodes,
            cells: self.cells,
        })
    }

    fn command_options(&self) -> String {
        format!(
            "--nodes {} --transport {} --ert {}{}",
            self.job.nodes,
            self.transport,
            self.job.ert.threshold,
            if self.job.canonical {
                " --canonical"
            } else {
                ""
            }
        )
    }
}
