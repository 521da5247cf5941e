//! A cluster job's one path: options validated once
//! ([`Valid<ClusterArgs>`](super::validate::Valid)), the scene read once and,
//! by what its data is, its mesh or volume loaded (or, for a `.pvtu` on
//! worker processes, its pieces' summaries: the workers read the cells) with the frame's
//! configuration ([`LoadedCluster`]), then run into a [`ClusterResult`]
//! (on a session, [`super::session::run`]). The command line and
//! [`super::ClusterJob::run`] both take it; nothing on it checks the
//! options or reads the scene again.

use super::cluster::ClusterArgs;
use super::cluster_grid::{self, GridFrames};
use super::cluster_mesh::{self, MeshFrame};
use super::cluster_pieces::{self, PieceFrames};
use super::validate::Valid;

/// A cluster job with its scene and data loaded, ready to run.
pub enum LoadedCluster<'a> {
    /// The frames of a mesh scene.
    Mesh(&'a ClusterArgs, Box<MeshFrame>),
    /// The frames of a grid scene.
    Grid(&'a ClusterArgs, Box<GridFrames>),
    /// The frames of a `.pvtu` mesh whose workers read their own pieces.
    Pieces(&'a ClusterArgs, Box<PieceFrames>),
}

impl<'a> Valid<'a, ClusterArgs> {
    /// Reads the scene and prepares a mesh frame or grid frames, by what
    /// the scene's data is (the one place that decides it).
    pub fn load(&self) -> anyhow::Result<LoadedCluster<'a>> {
        let a = self.args();
        let scene = super::load_scene(&a.scene)?;
        Ok(if super::render_grid::is_grid_scene(&scene) {
            LoadedCluster::Grid(a, Box::new(cluster_grid::load(a, scene)?))
        } else if cluster_pieces::reads_pieces(a, &scene) {
            LoadedCluster::Pieces(a, Box::new(cluster_pieces::load(a, scene)?))
        } else {
            LoadedCluster::Mesh(a, Box::new(cluster_mesh::load_mesh(a, scene)?))
        })
    }
}
