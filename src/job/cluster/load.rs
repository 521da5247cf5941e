//! A cluster job's one path: options validated once
//! ([`Valid<ClusterArgs>`](crate::job::validate::Valid)), the scene read once and,
//! by what its data is, its mesh or volume loaded (or, for a `.pvtu` on
//! worker processes, its pieces' summaries: the workers read the cells) with the frame's
//! configuration ([`LoadedCluster`]), then run into a [`ClusterResult`]
//! (on a session, [`crate::job::session::run`]). The command line and
//! [`crate::job::ClusterJob::run`] both take it; nothing on it checks the
//! options or reads the scene again.

use crate::job::cluster::grid::{self, GridFrames};
use crate::job::cluster::mesh::{self, MeshFrame};
use crate::job::cluster::pieces::{self, PieceFrames};
use crate::job::cluster::ClusterArgs;
use crate::job::validate::Valid;

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
        let scene = crate::job::load_scene(&a.scene)?;
        Ok(if crate::job::render::grid::is_grid_scene(&scene) {
            LoadedCluster::Grid(a, Box::new(grid::load(self, scene)?))
        } else if pieces::reads_pieces(a, &scene) {
            LoadedCluster::Pieces(a, Box::new(pieces::load(self, scene)?))
        } else {
            LoadedCluster::Mesh(a, Box::new(mesh::load_mesh(self, scene)?))
        })
    }
}
