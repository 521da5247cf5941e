//! `pvrsim cluster` on a grid scene (a scene whose data is a volume):
//! sort-last rendering of `d^3` bricks on grid nodes, layers composited in
//! visibility order (`parallel-texture-vr-rle.txt`). The paper's setting:
//! `--nodes 4 --subvolumes 2 --master --network 100base`.

use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;

use crate::cluster::grid::{self, GridConfig, GridOutcome};
use crate::cluster::remote::grid::GridRemote;
use crate::cluster::ClockKind;
use crate::compositor::strategy::Compositing;
use crate::job::args::transport::TransportArgs;
use crate::job::cluster::{load_profile, ClusterArgs};
use crate::net::tcp::Token;
use crate::node::grid::render::RendererKind;
use crate::node::grid::BrickPlacement;
use crate::render::slice3d::Slice3dOptions;
use crate::render::VolumeInput;
use crate::scene::Scene;

/// The grid configuration the arguments describe (mesh-only options refused).
pub fn config(v: &crate::job::Valid<'_, ClusterArgs>) -> anyhow::Result<GridConfig> {
    let a = v.args();
    let mut bad = Vec::new();
    if a.share || a.sharing != crate::job::cluster::Sharing::Off {
        bad.push("--share/--sharing");
    }
    if a.dlb {
        bad.push("--dlb");
    }
    if a.canonical {
        bad.push("--canonical");
    }
    if a.no_partial_composition {
        bad.push("--no-partial-composition");
    }
    if a.data.is_some() {
        bad.push("--data");
    }
    anyhow::ensure!(
        bad.is_empty(),
        "{} apply to cell projection (mesh scenes) only; grid nodes render bricks",
        bad.join(", ")
    );
    use crate::job::args::transport::TransportKind;
    let n = &a.net;
    n.worker_hook()?;
    anyhow::ensure!(
        (n.workers.is_empty() && n.hostfile.is_none() && n.token_file.is_none())
            || n.transport == Some(TransportKind::Tcp),
        "--workers, --hostfile and --token-file need --transport tcp"
    );
    let threads = match a.net.transport {
        None => false,
        Some(TransportKind::Threads) => true,
        Some(_) => true,
    };
    let g = &a.grid;
    let compositor = if g.master {
        anyhow::ensure!(
            g.radix_k.is_none(),
            "--radix-k sets radix-k's group size; --master composites every subimage at the \
             master (drop one of them)"
        );
        if let Some(c) = a.compositor.filter(|c| *c != Compositing::Master) {
            anyhow::bail!(
                "--master composites every subimage at the master; it cannot be combined with --compositor {c}"
            );
        }
        Compositing::Master
    } else {
        v.parsed().compositing
    };
    // `rle` (the default) means the paper's RLE at 16 bits for layers.
    let codec = a.codec.layers();
    let network = a.network.as_deref().unwrap_or("gbe");
    let (profile, profile_name) = load_profile(a.profile.as_deref().unwrap_or("radeon9700"))?;
    let renderer = match (g.blocks, g.tolerance) {
        (None, None) => RendererKind::Slice3d,
        (None, Some(_)) => anyhow::bail!(
            "--tolerance sets adaptive block sampling's tolerance: give --blocks B with it"
        ),
        (Some(blocks), t) => RendererKind::Adaptive {
            blocks,
            tolerance: t.unwrap_or(0.05),
        },
    };
    Ok(GridConfig {
        nodes: a.nodes,
        subvolumes: g.subvolumes.unwrap_or(2),
        master: g.master,
        placement: g.brick_placement.unwrap_or(BrickPlacement::RoundRobin),
        compositor,
        codec,
        slice: Slice3dOptions {
            ert: a.ert.threshold,
            ..Default::default()
        },
        renderer,
        clock: if threads {
            ClockKind::Wall
        } else {
            a.clock.unwrap_or(ClockKind::Virtual)
        },
        network: crate::job::cluster::load_network(network)?,
        network_name: network.to_string(),
        profile,
        profile_name,
        record_trace: true,
        texture_cache: !g.no_texture_cache,
    })
}

/// Grid frames ready to run: the scene and its volume (each read once),
/// the configuration and one camera per frame.
pub struct GridFrames {
    /// The scene with its volume.
    pub input: VolumeInput,
    /// The configuration.
    pub cfg: GridConfig,
    /// One camera per frame (`--frames`, `--turn`).
    pub cams: Vec<crate::scene::Camera>,
}

/// Prepares the frames of validated options on a grid `scene` (read once,
/// by the caller): refuses mesh-only options, builds the configuration and
/// the cameras, reads the volume.
pub fn load(v: &crate::job::Valid<'_, ClusterArgs>, scene: Scene) -> anyhow::Result<GridFrames> {
    let a = v.args();
    let cfg = config(v)?;
    anyhow::ensure!(
        a.series.series.is_none(),
        "--series replays a session of a mesh scene; a grid scene's series is an orbit \
         (--frames N --turn DEG)"
    );
    anyhow::ensure!(
        a.series.series_csv.is_none(),
        "--series-csv writes the rows of a mesh series; a grid series prints every frame's \
         wall time and its --report holds each frame's (drop --series-csv)"
    );
    let vol = crate::data::io::read_volume(&scene.data.path, &scene.data.field)
        .with_context(|| format!("cannot load the volume of scene {}", a.scene.display()))?;
    let (lo, hi) = vol.bounds();
    let mut input = VolumeInput::new(scene, Arc::new(vol))?;
    if let (Some(w), Some(h)) = (a.width, a.height) {
        input = input.with_size(w, h);
    }
    // The grid's box is its data: its corners decide a crop.
    let corners = crate::scene::orbit::box_corners(lo, hi);
    let image = &input.scene.image;
    let cams = a
        .series
        .orbit_cameras(&input.scene.camera, image.width, image.height, &corners)?;
    Ok(GridFrames { input, cfg, cams })
}

/// Runs every frame on the same nodes (on the transport `a` names).
pub fn run(a: &ClusterArgs, f: GridFrames) -> anyhow::Result<Vec<GridOutcome>> {
    let GridFrames { input, cfg, cams } = f;
    use crate::job::args::transport::TransportKind;
    let t = &a.net;
    match t.transport {
        None | Some(TransportKind::Threads) => grid::run_frames(&input, &cfg, &cams),
        Some(TransportKind::Processes) => {
            run_processes(t, &t.worker_program()?, &input, &cfg, &cams)
        }
        Some(TransportKind::Tcp) => {
            let (workers, token) = crate::job::nodes::tcp_workers(t, cfg.nodes)?;
            run_remote_frames(
                &remote(t, workers, token, TransportKind::Tcp),
                &input,
                &cfg,
                &cams,
            )
        }
        Some(TransportKind::Mpi) => anyhow::bail!(
            "--transport mpi: grid scenes run on threads, processes or tcp; under MPI only \
             mesh scenes run for now (use --transport processes or tcp for grids)"
        ),
    }
}

/// The coordinator of grid frames on `workers` with `t`'s options.
fn remote(
    t: &TransportArgs,
    workers: Vec<String>,
    token: Token,
    kind: crate::job::args::transport::TransportKind,
) -> GridRemote {
    GridRemote {
        workers,
        token,
        tcp: t.tcp_options(),
        recv_timeout: Duration::from_secs_f64(t.recv_timeout),
        transport: kind.name().to_string(),
        reassign: t.on_failure == crate::job::args::transport::OnFailure::Reassign,
    }
}

/// Grid frames, one per camera, over `--transport processes`: children of
/// `exe` (this program, or `pvrsim` from a test), one per node.
pub fn run_processes(
    t: &TransportArgs,
    program: &crate::cluster::remote::spawn::WorkerProgram,
    input: &VolumeInput,
    cfg: &GridConfig,
    cams: &[crate::scene::Camera],
) -> anyhow::Result<Vec<GridOutcome>> {
    use crate::job::args::transport::{OnFailure, TransportKind};
    // Reassigning, and every frame after the first (one session a frame),
    // need workers that serve more than one session.
    let serving = t.on_failure == OnFailure::Reassign || cams.len() > 1;
    let mut w = crate::job::nodes::spawn_processes(t, program, cfg.nodes, !serving)?;
    let r = remote(
        t,
        w.addrs.clone(),
        w.token().clone(),
        TransportKind::Processes,
    );
    let outs = run_remote_frames(&r, input, cfg, cams)?;
    // Serving workers, and every worker after a failed frame (one may be
    // stopped: no waiting for it), are killed and reaped on drop.
    if !serving {
        let bad = w.finish(Duration::from_secs(10));
        anyhow::ensure!(
            bad.is_empty(),
            "worker processes {bad:?} did not exit cleanly"
        );
    }
    Ok(outs)
}

/// One session per camera on the same workers (they keep their bricks and
/// textures from session to session).
fn run_remote_frames(
    r: &GridRemote,
    input: &VolumeInput,
    cfg: &GridConfig,
    cams: &[crate::scene::Camera],
) -> anyhow::Result<Vec<GridOutcome>> {
    let mut input = input.clone();
    let mut outs = Vec::with_capacity(cams.len());
    for (f, c) in cams.iter().enumerate() {
        input.scene.camera = *c;
        let t = std::time::Instant::now();
        let (mut out, _) = r
            .run(&input, cfg)
            .with_context(|| format!("frame {f} of {}", cams.len()))?;
        out.report.wall_s = t.elapsed().as_secs_f64();
        outs.push(out);
    }
    Ok(outs)
}
