//! What every renderer of a tetrahedral scene is given.

use std::sync::Arc;

use crate::data::TetMesh;
use crate::error::Result;
use crate::scene::Scene;

/// A scene with its mesh loaded and the field normalised to the transfer
/// function's `[0, 1]` scale: `s_norm = (s - range.0) / (range.1 - range.0)`.
#[derive(Debug, Clone)]
pub struct RenderInput {
    /// The scene.
    pub scene: Scene,
    /// The mesh.
    pub mesh: Arc<TetMesh>,
    /// Normalised scalar per vertex (not clamped: the TF clamps).
    pub s_norm: Vec<f64>,
    /// The range actually used (the scene's, or the field's min..max).
    pub range: [f64; 2],
    /// A `.pvtu`'s pieces: each one's tetrahedra, the mesh holding them in
    /// turn (`None` for one file). `--placement pieces` places by them.
    pub pieces: Option<Arc<[u64]>>,
    /// How the load path renumbered the scene's mesh (`None`: the file's
    /// numbering), kept until a series' time steps are read and numbered
    /// alike ([`crate::data::io::read_mesh_like`]).
    pub renumbering: Option<Arc<crate::data::locality::Renumbering>>,
}

/// A raw scalar `s` on the transfer function's `[0, 1]` scale for the
/// field's `range` (not clamped: the TF clamps); every value is 0 when the
/// range is empty. The one formula wherever vertices are normalised (a
/// whole mesh here, a worker's own pieces), so that they agree bit for bit.
#[inline]
pub fn normalised(s: f64, range: [f64; 2]) -> f64 {
    let span = range[1] - range[0];
    if span > 0.0 {
        (s - range[0]) / span
    } else {
        0.0
    }
}

impl RenderInput {
    /// Normalises `scene.data.field` of `mesh`. A constant field with no
    /// explicit range maps every vertex to `s_norm = 0`.
    pub fn new(scene: Scene, mesh: Arc<TetMesh>) -> Result<RenderInput> {
        let raw = mesh.scalar(&scene.data.field)?;
        let range = match scene.data.range {
            Some(r) => r,
            None => {
                let lo = raw.iter().cloned().fold(f64::INFINITY, f64::min);
                let hi = raw.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                if raw.is_empty() {
                    [0.0, 1.0]
                } else {
                    [lo, hi]
                }
            }
        };
        let s_norm = raw.iter().map(|&s| normalised(s, range)).collect();
        Ok(RenderInput {
            scene,
            mesh,
            s_norm,
            range,
            pieces: None,
            renumbering: None,
        })
    }
}

impl RenderInput {
    /// Reads the scene file and its mesh; returns the input and the seconds
    /// spent reading the mesh.
    pub fn load(scene_path: &std::path::Path) -> Result<(RenderInput, f64)> {
        RenderInput::read(Scene::load(scene_path)?)
    }

    /// Reads `scene`'s mesh (a `.pvtu`'s pieces noted in
    /// [`RenderInput::pieces`]); returns the input and the seconds spent
    /// reading the mesh.
    pub fn read(scene: Scene) -> Result<(RenderInput, f64)> {
        let t = std::time::Instant::now();
        let l = crate::data::io::load_mesh(&scene.data.path)?;
        let load_s = t.elapsed().as_secs_f64();
        let mut input = RenderInput::new(scene, Arc::new(l.mesh))?;
        input.pieces = l.pieces.map(Arc::from);
        input.renumbering = l.renumbering.map(Arc::new);
        Ok((input, load_s))
    }

    /// Frees the mesh's point-data fields: a frame reads only
    /// [`RenderInput::s_norm`] (a solver's files carry several fields: the
    /// 20 M-tet demo's are 139 MB, 7 B a tetrahedron). Does nothing while the
    /// mesh is shared (a series' other time steps may render another field).
    /// Callers that report the field (its components) do so first.
    pub fn release_fields(&mut self) {
        if let Some(mesh) = Arc::get_mut(&mut self.mesh) {
            mesh.fields = Vec::new();
        }
    }

    /// The same input with the image size replaced (camera unchanged: an
    /// orthographic view keeps its world height).
    pub fn with_size(mut self, width: u32, height: u32) -> RenderInput {
        self.scene.image.width = width;
        self.scene.image.height = height;
        self
    }
}
