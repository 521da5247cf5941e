//! A mesh cluster job whose workers read their own pieces: the scene's data
//! is a `.pvtu` and the frame runs on `--transport processes`, `tcp` or
//! `mpi` without `--placement` ([`reads_pieces`]). The coordinator reads the
//! `.pvtu` and the pieces' vertices (the field's and depth ranges), never the
//! cells ([`crate::cluster::remote::pieces`]); the pieces are the initial
//! placement. Frames of an orbit (`--frames`, `--turn`) run on the same
//! workers, which read their pieces once.

use anyhow::Context;

use crate::cluster::remote::pieces::PieceSet;
use crate::cluster::remote::Measured;
use crate::cluster::report::transport::PiecesSection;
use crate::cluster::series::Step;
use crate::cluster::ClusterConfig;
use crate::job::args::transport::TransportKind;
use crate::job::cluster::mesh::mesh_config;
use crate::job::cluster::{ClusterArgs, Sharing};
use crate::node::piece_map::Share;
use crate::node::PlacementMethod;
use crate::scene::Scene;

/// Frames ready to run on workers that read their pieces.
pub struct PieceFrames {
    /// What the coordinator read of the pieces.
    pub pieces: PieceSet,
    /// The scene of each frame (its camera and transfer function).
    pub scenes: Vec<Scene>,
    /// One step per frame (for the series report).
    pub steps: Vec<Step>,
    /// The configuration.
    pub cfg: ClusterConfig,
    kind: TransportKind,
}

impl PieceFrames {
    /// The transport the workers run on (`processes`, `tcp` or `mpi`).
    pub fn kind(&self) -> TransportKind {
        self.kind
    }
}

/// Whether `scene` runs with the workers reading their own pieces (the one
/// place that decides it): a `.pvtu` on worker processes, TCP workers or
/// MPI ranks, placed by its pieces (no `--placement`).
pub fn reads_pieces(a: &ClusterArgs, scene: &Scene) -> bool {
    let pvtu =
        crate::data::io::mesh_format(&scene.data.path) == Some(crate::data::io::MeshFormat::Pvtu);
    pvtu && matches!(a.placement, None | Some(PlacementMethod::Pieces))
        && matches!(
            a.net.transport,
            Some(TransportKind::Processes | TransportKind::Tcp | TransportKind::Mpi)
        )
}

/// Prepares the frames: the configuration (as for any mesh frame), the
/// pieces' summaries, one scene per camera. Refuses what needs the cells
/// in the coordinator.
pub fn load(
    v: &crate::job::Valid<'_, ClusterArgs>,
    mut scene: Scene,
) -> anyhow::Result<PieceFrames> {
    let a = v.args();
    crate::job::args::grid::refuse_on_mesh(&a.grid)?;
    let why = "the workers read their own pieces of the .pvtu and the coordinator never holds \
               the cells; give --placement rcb to read the whole mesh in the coordinator and \
               send each worker its cells";
    anyhow::ensure!(
        a.series.series.is_none(),
        "--series with a .pvtu on worker processes: {why}"
    );
    anyhow::ensure!(
        a.sharing != Sharing::Overlap,
        "--sharing overlap with a .pvtu on worker processes (the nodes' screen footprints \
         need the cells): {why}"
    );
    if let (Some(w), Some(h)) = (a.width, a.height) {
        scene.image.width = w;
        scene.image.height = h;
    }
    let (mut cfg, remote) = mesh_config(v, [scene.image.width, scene.image.height])?;
    cfg.placement = PlacementMethod::Pieces;
    let kind = remote.context("workers reading pieces need a remote transport (internal error)")?;
    let pieces = PieceSet::open(&scene, a.nodes)
        .with_context(|| format!("cannot load scene {}", a.scene.display()))?;
    if pieces.splits() {
        let per: Vec<String> = pieces
            .units()
            .iter()
            .filter(|s| s.part == 0)
            .map(|s| s.of.to_string())
            .collect();
        tracing::info!(
            "{} has {} pieces for {} nodes: each piece is split over {} nodes (by its cells' \
             centroids; every node reads its piece and keeps its part)",
            pieces.path().display(),
            pieces.summary.pieces.len(),
            a.nodes,
            per.join(", ")
        );
    }
    anyhow::ensure!(
        !a.series.fit_orbit,
        "--fit-orbit fits the view to the data's vertices, which only the workers read from \
         their pieces here: widen the scene's camera (orthographic height or fov_y_deg) instead"
    );
    let steps: Vec<Step> = a
        .series
        .cameras(&scene.camera)?
        .into_iter()
        .map(|camera| Step {
            data: 0,
            camera,
            transfer: scene.transfer.clone(),
        })
        .collect();
    let scenes = steps
        .iter()
        .map(|s| {
            let mut f = scene.clone();
            f.camera = s.camera;
            f
        })
        .collect();
    Ok(PieceFrames {
        pieces,
        scenes,
        steps,
        cfg,
        kind,
    })
}

/// The report's pieces section of a frame: what the coordinator read, the
/// parts (after any reassignment) and what the transport measured.
pub fn section(pieces: &PieceSet, cfg: &ClusterConfig, m: Measured) -> PiecesSection {
    // The parts are the piece map's units (pieces, or parts of split ones).
    let units = match &m.reassigned {
        Some(r) => r.parts.clone(),
        None => pieces.parts(cfg.phase1.nodes),
    };
    let shares: Vec<Vec<Share>> = units
        .iter()
        .map(|part| part.iter().map(|&u| pieces.units()[u as usize]).collect())
        .collect();
    let parts = shares
        .iter()
        .map(|s| {
            let mut p: Vec<u32> = s.iter().map(|x| x.piece).collect();
            p.dedup();
            p
        })
        .collect();
    PiecesSection {
        pvtu: pieces.path().display().to_string(),
        pieces: pieces.summary.pieces.len(),
        vertices_read_by_coordinator: pieces.summary.points(),
        parts,
        shares: pieces.splits().then_some(shares),
        setup_s: m.setup_s,
        phase1_wire_bytes: m.phase1.wire_bytes_sent,
        phase2_wire_bytes: m.phase2.wire_bytes_sent,
        reassigned: m.reassigned,
    }
}
