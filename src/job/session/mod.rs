//! A cluster session ([`Session`]): a mesh scene's nodes set up once and
//! kept between frames, on every transport the job names: the simulated
//! cluster or threads in this process (each node's cells and vertex data
//! built once per data state, [`crate::cluster::series::LocalFrames`]),
//! worker processes, TCP workers or MPI ranks (connected once, their cells
//! sent once or their pieces read once,
//! [`crate::cluster::remote::LiveNodes`]).
//! Each frame carries only what changed: camera, transfer function, time
//! step, image size. `pvrsim cluster --frames/--series`, the Python
//! module's `Session` and the viewer all run their frames here.
//!
//! - [`run`]: a loaded job's frames on a session, each handed on as it
//!   ends; where the nodes run is [`crate::job::nodes`]'s.

pub mod run;

use crate::cluster::remote::spawn::WorkerProgram;
use crate::cluster::remote::{transport_section, Measured, Work};
use crate::cluster::series::{Coherence, LocalFrames, Step};
use crate::cluster::{ClusterConfig, ClusterOutcome};
use crate::job::args::transport::TransportKind;
use crate::job::cluster::load::LoadedCluster;
use crate::job::cluster::ClusterArgs;
use crate::job::{nodes, JobError, Valid};
use crate::render::RenderInput;
use crate::scene::{Camera, Scene, TransferFunction};

/// What one frame changes against the session's last frame (`None`:
/// keep it).
#[derive(Debug, Clone, Default)]
pub struct FrameRequest {
    /// The camera.
    pub camera: Option<Camera>,
    /// The transfer function.
    pub transfer: Option<TransferFunction>,
    /// The data state (time step) among the session's inputs.
    pub step: Option<usize>,
    /// The image size in pixels (a reduced-resolution interactive frame).
    pub size: Option<(u32, u32)>,
}

/// One frame of a session with what the transport measured: the outcome
/// (its report carries the transport section on a real transport), the
/// wall seconds from the request to the image, the bytes on the wire and
/// the cells' bytes sent for it.
pub struct SessionFrame {
    /// The frame, as a one-off `pvrsim cluster` frame gives it.
    pub outcome: ClusterOutcome,
    /// Wall seconds of the frame (measured on real transports; the
    /// report's frame time otherwise).
    pub wall_s: f64,
    /// Measured bytes (wire, cells) on real transports.
    pub bytes: Option<(u64, u64)>,
    /// The slowest worker's compress seconds on real transports.
    pub compress_s: Option<f64>,
}

/// Where the session's nodes are.
enum Engine {
    /// The simulated cluster or threads, in this process.
    Local(LocalFrames),
    /// Workers that get their cells from this process.
    Cells(nodes::RemoteNodes, ClusterConfig),
    /// Workers that read their own pieces of a `.pvtu`.
    Pieces(
        nodes::RemoteNodes,
        Box<crate::cluster::remote::pieces::PieceSet>,
        ClusterConfig,
    ),
}

/// A cluster that stays up between frames (see the module docs).
pub struct Session {
    engine: Engine,
    /// The data states (a mesh and field each; empty for pieces).
    inputs: Vec<RenderInput>,
    /// The scene the session was opened on (for pieces: its data).
    scene: Scene,
    /// The last frame's step and image size.
    last: Step,
    size: (u32, u32),
    frames: usize,
}

impl Session {
    /// Validates the cluster job once, loads its scene and data once and
    /// sets up its nodes (worker processes are spawned, TCP workers are
    /// dialled at the first frame, MPI ranks wait for theirs). Mesh scenes
    /// only.
    pub fn open(job: &ClusterArgs) -> Result<Session, JobError> {
        Session::open_with(job, &job.net.worker_program().map_err(JobError::Failed)?)
    }

    /// [`Session::open`], worker processes (`--transport processes`)
    /// started as `program` (a `pvrsim` binary: this program when it is
    /// one, or the one a test or an embedding program names).
    pub fn open_with(job: &ClusterArgs, program: &WorkerProgram) -> Result<Session, JobError> {
        let valid = Valid::new(job).map_err(JobError::Invalid)?;
        let loaded = valid.load().map_err(JobError::Failed)?;
        Session::from_loaded(loaded, program).map_err(JobError::Failed)
    }

    /// A session of a loaded job, worker processes started from `exe`.
    pub(crate) fn from_loaded(
        loaded: LoadedCluster<'_>,
        program: &WorkerProgram,
    ) -> anyhow::Result<Session> {
        match loaded {
            LoadedCluster::Grid(a, _) => anyhow::bail!(
                "{}: a grid scene on a cluster runs its frames as a job (pvrsim cluster \
                 --frames); a session holds a mesh",
                a.scene.display()
            ),
            LoadedCluster::Mesh(a, f) => {
                let coherence = coherence(a, f.remote, &f.cfg);
                let first = f.steps.first().cloned().expect("at least one step");
                Session::of_mesh(a, f.inputs, f.cfg, f.remote, coherence, first, program)
            }
            LoadedCluster::Pieces(a, f) => {
                let kind = f.kind();
                let n = f.cfg.phase1.nodes;
                let remote = nodes::open(&a.net, kind, n, program)?;
                let scene = f.scenes.first().cloned().expect("at least one frame");
                let first = f.steps.first().cloned().expect("at least one step");
                Ok(Session {
                    size: (scene.image.width, scene.image.height),
                    engine: Engine::Pieces(remote, Box::new(f.pieces), f.cfg),
                    inputs: Vec::new(),
                    scene,
                    last: first,
                    frames: 0,
                })
            }
        }
    }

    /// A mesh session over `inputs` (one per data state).
    pub(crate) fn of_mesh(
        a: &ClusterArgs,
        inputs: Vec<RenderInput>,
        cfg: ClusterConfig,
        remote: Option<TransportKind>,
        coherence: Coherence,
        first: Step,
        program: &WorkerProgram,
    ) -> anyhow::Result<Session> {
        let scene = inputs
            .first()
            .map(|i| i.scene.clone())
            .ok_or_else(|| anyhow::anyhow!("a session needs data (internal error)"))?;
        let engine = match remote {
            None => Engine::Local(LocalFrames::new(cfg, coherence)),
            Some(TransportKind::Threads) => anyhow::bail!(
                "--transport {}: a session runs in this process, on worker processes or on TCP \
                 workers (internal error)",
                remote.map_or("", |k| k.name())
            ),
            Some(kind) => {
                let n = cfg.phase1.nodes;
                Engine::Cells(nodes::open(&a.net, kind, n, program)?, cfg)
            }
        };
        Ok(Session {
            size: (scene.image.width, scene.image.height),
            engine,
            inputs,
            scene,
            last: first,
            frames: 0,
        })
    }

    /// The scene the session was opened on (camera, transfer function,
    /// image).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The number of data states (time steps) the session holds.
    pub fn steps(&self) -> usize {
        self.inputs.len().max(1)
    }

    /// Frames run so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// One frame on the session's nodes with `req`'s changes; the outcome
    /// is what a one-off `pvrsim cluster` frame at that camera gives.
    pub fn frame(&mut self, req: &FrameRequest) -> Result<ClusterOutcome, JobError> {
        let mut step = self.last.clone();
        if let Some(c) = req.camera {
            step.camera = c;
        }
        if let Some(t) = &req.transfer {
            step.transfer = t.clone();
        }
        if let Some(d) = req.step {
            if d >= self.steps() {
                return Err(JobError::Invalid(anyhow::anyhow!(
                    "time step {d} does not exist: the session holds {} (0..{})",
                    self.steps(),
                    self.steps() - 1
                )));
            }
            step.data = d;
        }
        let size = req.size.unwrap_or(self.size);
        if size.0 == 0 || size.1 == 0 {
            return Err(JobError::Invalid(anyhow::anyhow!(
                "image size {}x{}: both must be at least 1",
                size.0,
                size.1
            )));
        }
        self.run_step(&step, size)
            .map(|f| f.outcome)
            .map_err(JobError::Failed)
    }

    /// One frame of `step` at `size` pixels, with what the transport
    /// measured.
    pub(crate) fn run_step(
        &mut self,
        step: &Step,
        size: (u32, u32),
    ) -> anyhow::Result<SessionFrame> {
        let t0 = std::time::Instant::now();
        let resized = size != (self.scene.image.width, self.scene.image.height);
        let f = match &mut self.engine {
            Engine::Local(nodes) => {
                let out = if resized {
                    let inputs = [step.input(&self.inputs).with_size(size.0, size.1)];
                    let one = Step {
                        data: 0,
                        ..step.clone()
                    };
                    // A new image size: nodes of that size (the kept data
                    // is per data state and camera independent, not size).
                    LocalFrames::new(nodes.config().clone(), Coherence::Off).frame(&inputs, &one)?
                } else {
                    nodes.frame(&self.inputs, step)?
                };
                SessionFrame {
                    wall_s: out.report.frame_s,
                    outcome: out,
                    bytes: None,
                    compress_s: None,
                }
            }
            Engine::Cells(remote, cfg) => {
                let mut input = step.input(&self.inputs);
                if resized {
                    input = input.with_size(size.0, size.1);
                }
                let (out, m) = remote
                    .live
                    .frame(Work::Cells(&input, step.data as u64), cfg)?;
                measured_frame(out, &input, cfg, m, t0)?
            }
            Engine::Pieces(remote, pieces, cfg) => {
                let mut scene = self.scene.clone();
                scene.camera = step.camera;
                scene.transfer = step.transfer.clone();
                scene.image.width = size.0;
                scene.image.height = size.1;
                let (mut outcome, m) = remote.live.frame(Work::Pieces(pieces, &scene), cfg)?;
                let wall_s = t0.elapsed().as_secs_f64();
                let bytes = Some((m.frame_bytes(), m.cells_bytes_sent));
                let compress_s = m.compress_s();
                outcome.report.pieces = Some(crate::job::cluster::pieces::section(pieces, cfg, m));
                SessionFrame {
                    outcome,
                    wall_s,
                    bytes,
                    compress_s,
                }
            }
        };
        self.last = step.clone();
        self.size = size;
        self.frames += 1;
        Ok(f)
    }

    /// Ends the nodes: workers are told the session is over and exit;
    /// nothing of it is left running.
    pub fn close(self) -> Result<(), JobError> {
        match self.engine {
            Engine::Local(_) => Ok(()),
            Engine::Cells(remote, _) | Engine::Pieces(remote, ..) => {
                remote.close().map_err(JobError::Failed)
            }
        }
    }
}

/// A frame measured on a real transport: the transport section in its
/// report, its wall seconds since `t0` and its bytes.
fn measured_frame(
    mut out: ClusterOutcome,
    input: &RenderInput,
    cfg: &ClusterConfig,
    m: Measured,
    t0: std::time::Instant,
) -> anyhow::Result<SessionFrame> {
    let wall_s = t0.elapsed().as_secs_f64();
    let bytes = Some((m.frame_bytes(), m.cells_bytes_sent));
    let compress_s = m.compress_s();
    out.report.transport = Some(transport_section(input, cfg, &out, m)?);
    Ok(SessionFrame {
        outcome: out,
        wall_s,
        bytes,
        compress_s,
    })
}

/// How a series in this process keeps its placement (`--coherence`; off
/// on real transports).
pub(crate) fn coherence(
    a: &ClusterArgs,
    remote: Option<TransportKind>,
    cfg: &ClusterConfig,
) -> Coherence {
    match (remote, a.series.coherence) {
        (Some(_), _) => Coherence::Off,
        (None, Some(c)) => c,
        (None, None) if cfg.phase1.data == crate::node::DataMode::Partitioned => {
            Coherence::Placement
        }
        (None, None) => Coherence::Off,
    }
}
