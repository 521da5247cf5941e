//! A dataset is either a tetrahedral mesh or a regular grid; the CLI and
//! scene loading accept both and pick the renderer from the kind.

use std::path::Path;

use crate::data::{TetMesh, Volume};
use crate::error::{Error, Result};

/// A loaded dataset.
#[derive(Debug, Clone)]
pub enum Dataset {
    /// Tetrahedra with point fields (`.vtk`, `.vtu`, `.pvtu`, `.inp`).
    Mesh(TetMesh),
    /// A regular grid (`.nrrd`, `.nhdr`, `.nii`, `.nii.gz`, `.vti`, `.fld`).
    Volume(Volume),
}

impl Dataset {
    /// The mesh, if this is one.
    pub fn as_mesh(&self) -> Option<&TetMesh> {
        match self {
            Dataset::Mesh(m) => Some(m),
            Dataset::Volume(_) => None,
        }
    }

    /// The volume, if this is one.
    pub fn as_volume(&self) -> Option<&Volume> {
        match self {
            Dataset::Volume(v) => Some(v),
            Dataset::Mesh(_) => None,
        }
    }
}

/// Whether a file name is one of the mesh formats.
pub fn is_mesh_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .is_some_and(|e| matches!(e.as_str(), "vtk" | "vtu" | "pvtu" | "inp"))
}

/// Reads a mesh or a volume, choosing by the file name. `field` is passed
/// to [`read_volume`](crate::data::io::read_volume) (meshes keep all their
/// fields; the renderer picks one).
pub fn read_dataset(path: &Path, field: &str) -> Result<Dataset> {
    if is_mesh_file(path) {
        return crate::data::io::read_mesh(path).map(Dataset::Mesh);
    }
    if crate::data::io::volume::volume_format(path).is_some() {
        return crate::data::io::read_volume(path, field).map(Dataset::Volume);
    }
    Err(Error::data(
        path,
        "file name",
        format!(
            "unsupported data format; meshes: {}; volumes: {}",
            crate::data::io::SUPPORTED,
            crate::data::io::volume::SUPPORTED
        ),
    ))
}
