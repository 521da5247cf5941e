//! A mesh cluster job's frames: the scene's mesh read once with the
//! frame's configuration ([`load_mesh`], [`mesh_config`]), then run in this
//! process or on the workers the transport names (on a session,
//! [`crate::job::session`]). The options live in [`crate::job::cluster`].

use anyhow::Context;

use crate::cluster::ClusterConfig;
use crate::job::cluster::{config, ClusterArgs};
use crate::job::memory::{self, FrameKind};
use crate::node::{DataMode, PlacementMethod};
use crate::render::RenderInput;

/// Mesh frames ready to run: the scene and its mesh (each read once),
/// the configuration, the cameras, and where they run (`None`: this process).
pub struct MeshFrame {
    /// The scene with its mesh, then each other time step of a series.
    pub inputs: Vec<RenderInput>,
    /// The configuration.
    pub cfg: ClusterConfig,
    /// One step per frame (`--frames`, `--turn`, `--series`; one without them).
    pub steps: Vec<crate::cluster::series::Step>,
    /// Where they run (`None`: this process).
    pub remote: Option<crate::job::args::transport::TransportKind>,
}

/// Prepares a mesh frame of validated options on `scene` (read once, by
/// the caller): refuses grid-only options, reads the mesh, builds the
/// configuration and checks memory and the transport's set-up.
pub fn load_mesh(
    v: &crate::job::Valid<'_, ClusterArgs>,
    scene: crate::scene::Scene,
) -> anyhow::Result<MeshFrame> {
    let a = v.args();
    crate::job::args::grid::refuse_on_mesh(&a.grid)?;
    let (mut input, _) = RenderInput::read(scene)
        .with_context(|| format!("cannot load scene {}", a.scene.display()))?;
    if let (Some(w), Some(h)) = (a.width, a.height) {
        input = input.with_size(w, h);
    }
    crate::job::warn_field(&input);
    let (mut cfg, remote) = mesh_config(v, [input.scene.image.width, input.scene.image.height])?;
    match (a.placement, &input.pieces) {
        // A .pvtu is placed by its pieces unless told otherwise.
        (None, Some(_)) => cfg.placement = PlacementMethod::Pieces,
        (Some(PlacementMethod::Pieces), None) => anyhow::bail!(
            "--placement pieces: the scene's data {} is one file; pieces come from a .pvtu \
             (pvrsim partition MESH --pieces P -o OUT.pvtu writes one)",
            input.scene.data.path.display()
        ),
        _ => {}
    }
    let (mut inputs, steps) = crate::job::series::steps::mesh_steps(&a.series, input)?;
    if let [one] = inputs.as_mut_slice() {
        one.release_fields();
    }
    Ok(MeshFrame {
        inputs,
        cfg,
        steps,
        remote,
    })
}

/// The configuration of a mesh frame of `image` pixels and where it runs
/// (`None`: this process): checks memory, the node count and what the
/// transport accepts (remote workers hold partitioned data).
pub(super) fn mesh_config(
    v: &crate::job::Valid<'_, ClusterArgs>,
    image: [u32; 2],
) -> anyhow::Result<(
    ClusterConfig,
    Option<crate::job::args::transport::TransportKind>,
)> {
    let a = v.args();
    let mut cfg = config(v)?;
    memory::check_fits(
        image[0],
        image[1],
        FrameKind::Cluster { nodes: a.nodes },
        crate::budget::available_bytes(),
    )?;
    // After the memory check, whose message says what a huge count costs.
    anyhow::ensure!(
        a.nodes <= 65_536,
        "--nodes {} is more than this simulator supports (65536)",
        a.nodes
    );
    let remote = a.net.apply(&mut cfg)?;
    if remote.is_some() {
        anyhow::ensure!(
            a.ert_mode.manager_shards.is_none_or(|k| k == 1),
            "--manager-shards runs on the simulated cluster (or --transport threads) only: \
             remote workers talk to one manager"
        );
        if a.ert_mode.manager_shards.is_none() && a.nodes > 16 {
            eprintln!(
                "note: remote workers talk to one manager: 1 manager shard (the simulated \
                 cluster's default for {} nodes would be {})",
                a.nodes,
                a.nodes.div_ceil(crate::node::shard_map::NODES_PER_SHARD)
            );
        }
        if cfg.phase1.data == DataMode::Replicated {
            anyhow::ensure!(
                a.data.is_none(),
                "--data replicated runs on the simulated cluster only: remote workers receive their part of the mesh, not all of it; give --data partitioned"
            );
            eprintln!("note: remote workers hold their part of the mesh only: --data partitioned (cells move with their vertices)");
            cfg.phase1.data = DataMode::Partitioned;
            anyhow::ensure!(
                a.ert_mode.schedule_waves.is_none_or(|w| w <= 1),
                "--schedule-waves needs replicated data, which runs on the simulated cluster only"
            );
            cfg.phase1.schedule_waves = 0;
        }
    }
    Ok((cfg, remote))
}
