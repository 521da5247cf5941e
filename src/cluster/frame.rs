//! What a frame's driver and its report need of the data ([`FrameData`]):
//! the mesh this process holds, or, when the workers read their own
//! pieces of a partitioned mesh ([`crate::cluster::remote::pieces`]), only
//! the scene and what the coordinator learnt of the pieces.

use crate::render::RenderInput;
use crate::scene::Scene;

/// A frame's data as its driver and report see it.
#[derive(Debug, Clone, Copy)]
pub enum FrameData<'a> {
    /// The scene and its whole mesh, in this process.
    Mesh(&'a RenderInput),
    /// The scene; the cells are on the workers, which read them.
    Pieces {
        /// The scene.
        scene: &'a Scene,
        /// Tetrahedra the workers hold (their `Ready` counts; 0 before).
        cells: u64,
        /// The depth range over every piece's vertices.
        depth_range: [f32; 2],
    },
}

impl<'a> FrameData<'a> {
    /// The scene.
    pub fn scene(&self) -> &'a Scene {
        match self {
            FrameData::Mesh(i) => &i.scene,
            FrameData::Pieces { scene, .. } => scene,
        }
    }

    /// Tetrahedra in the frame.
    pub fn cells_total(&self) -> u64 {
        match self {
            FrameData::Mesh(i) => i.mesh.tets.len() as u64,
            FrameData::Pieces { cells, .. } => *cells,
        }
    }

    /// The depth range of per-pixel sharing's codes
    /// ([`crate::cluster::phase1::depth_range`]).
    pub fn depth_range(&self) -> [f32; 2] {
        match self {
            FrameData::Mesh(i) => crate::cluster::phase1::depth_range(i),
            FrameData::Pieces { depth_range, .. } => *depth_range,
        }
    }
}
