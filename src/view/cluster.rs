//! The viewer's frames on a cluster (`pvrsim view --nodes N`): a
//! persistent [`Session`] (nodes set up and the data placed once; each
//! frame carries the camera, transfer function, size and data state), with
//! the per-node figures of each frame's report. The session holds every
//! data state the page can choose (each field of each time step,
//! [`DataStates`]), so that a field or time-step change is one frame.

use crate::job::args::transport::TransportKind;
use crate::job::cluster::load::LoadedCluster;
use crate::job::render::loaded::DataStates;
use crate::job::render::{RenderArgs, RendererKind};
use crate::job::{ClusterJob, FrameRequest, LoadedRender, Session, Valid, ViewChange};
use crate::scene::Scene;

use super::backend::{
    chosen, coarse_frame, coarse_of, reduced, step_names, step_paths, Backend, Info, Rendered,
    HISTOGRAM_BINS,
};
use super::pace::Level;

/// The session of `job` holding the data states of `states` (the scene's
/// first, as the job loads it; more than one: every field and time step).
fn open_session(job: &ClusterJob, states: &DataStates) -> anyhow::Result<Session> {
    let inputs = &states.inputs;
    let valid = Valid::new(job)?;
    let loaded = match valid.load()? {
        LoadedCluster::Mesh(a, mut f) if inputs.len() > 1 => {
            f.inputs = inputs.to_vec();
            LoadedCluster::Mesh(a, f)
        }
        LoadedCluster::Pieces(..) if inputs.len() > 1 => anyhow::bail!(
            "{}: workers that read their own pieces of a .pvtu hold its scene's field only; \
             view it without --series (one field), or without --nodes",
            job.scene.display()
        ),
        other => other,
    };
    Session::from_loaded(loaded, &job.net.worker_program()?)
}

/// On a cluster: frames on a persistent session ([`Session`]: the nodes
/// set up and the data placed once, each frame carrying the camera,
/// transfer function, size and data state).
pub struct Cluster {
    job: ClusterJob,
    session: Option<Session>,
    /// Every data state (inputs also held by the session), the one shown
    /// (time step, field, state) and each state's histogram and range.
    states: DataStates,
    step: usize,
    field: String,
    state: usize,
    summaries: Vec<(Vec<u64>, [f64; 2])>,
    coarse_wanted: bool,
    /// The coarse stand-in of the mesh, drawn in this process while the
    /// user moves the view (`--interactive-scale auto`; as ParaView draws
    /// its level of detail on the client), with the options it is drawn
    /// with.
    coarse: Option<(LoadedRender, RenderArgs)>,
    coarse_state: usize,
    cells: usize,
    scene: Scene,
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
        if let Some(argv) = &args.worker_argv {
            job.net.set_worker_argv(argv.clone())?;
        }
        job.ert.threshold = r.ert.threshold;
        job.canonical = r.canonical;
        job.width = r.width;
        job.height = r.height;
        anyhow::ensure!(
            r.renderer.is_none() || r.renderer == Some(RendererKind::Cell),
            "--renderer with --nodes: a cluster draws meshes by cell projection; leave --renderer out"
        );
        let (mut loaded, states) = Valid::new(r)?.load_states(args.series.as_deref())?;
        anyhow::ensure!(
            !loaded.is_grid(),
            "{}: `pvrsim view --nodes` serves mesh scenes (a cluster session holds a mesh); view \
             a grid without --nodes",
            r.scene.display()
        );
        let mut summaries = Vec::new();
        for input in &states.inputs {
            loaded.select(input);
            summaries.push((loaded.histogram(HISTOGRAM_BINS), loaded.range()));
        }
        if let Some(first) = states.inputs.first() {
            loaded.select(first);
        }
        let field = loaded.scene().data.field.clone();
        let cells = match &loaded {
            LoadedRender::Mesh(m) => m.mesh.tets.len(),
            LoadedRender::Grid(_) => 0,
        };
        let coarse_wanted = args.interactive_scale == super::InteractiveScale::Auto;
        let coarse = coarse_wanted
            .then(|| coarse_of(&loaded))
            .flatten()
            .map(|c| {
                let mut a = r.clone();
                a.renderer = Some(RendererKind::Cell);
                (c, a)
            });
        drop(loaded);
        let session = open_session(&job, &states)?;
        let scene = session.scene().clone();
        Ok(Cluster {
            job,
            session: Some(session),
            states,
            step: 0,
            field,
            state: 0,
            summaries,
            coarse_wanted,
            coarse,
            coarse_state: 0,
            cells,
            scene,
            transport: transport.name().to_string(),
        })
    }

    fn session(&mut self) -> anyhow::Result<&mut Session> {
        if self.session.is_none() {
            self.session = Some(open_session(&self.job, &self.states)?);
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
            field: self.field.clone(),
            fields: self.states.fields.clone(),
            steps: step_names(&self.states),
            step_paths: step_paths(&self.states),
            step: self.step,
            range: self.summaries.get(self.state).map_or([0.0, 1.0], |s| s.1),
            histogram: self
                .summaries
                .get(self.state)
                .map(|s| s.0.clone())
                .unwrap_or_default(),
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

    /// The next frame names the state; the coarse stand-in of a large
    /// mesh is rebuilt for it (in this process).
    fn select(&mut self, step: Option<usize>, field: Option<&str>) -> anyhow::Result<()> {
        let (step, field, state) = chosen(&self.states, (self.step, &self.field), step, field)?;
        if let Some(input) = self.states.inputs.get(state) {
            // The scene /scene.toml writes names the state's data.
            self.scene.data = input.scene.data.clone();
            if self.coarse_wanted && state != self.coarse_state {
                if let Some((c, _)) = self.coarse.as_mut() {
                    let mut l = LoadedRender::Mesh(Box::new(input.clone()));
                    l.apply(&ViewChange {
                        camera: Some(self.scene.camera),
                        transfer: Some(self.scene.transfer.clone()),
                        size: None,
                    })?;
                    if let Some(n) = coarse_of(&l) {
                        *c = n;
                    }
                    self.coarse_state = state;
                }
            }
        }
        (self.step, self.field, self.state) = (step, field, state);
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
            step: Some(self.state),
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
