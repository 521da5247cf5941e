//! A dataset is either a tetrahedral mesh or a regular grid; the CLI and
//! scene loading accept both and pick the renderer from the kind.

use std::path::Path;

use crate::data::io::volume::{volume_format, VolumeFormat};
use crate::data::io::{mesh_format, MeshFormat};
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

/// The format of a data file: a mesh or a volume format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataFormat {
    /// A tetrahedral mesh format.
    Mesh(MeshFormat),
    /// A regular-grid format.
    Volume(VolumeFormat),
}

/// The format a data file's name asks for, or `None`: the one decision
/// every command and the Python module use ([`mesh_format`] for meshes,
/// [`volume_format`] for grids).
pub fn data_format(path: &Path) -> Option<DataFormat> {
    mesh_format(path)
        .map(DataFormat::Mesh)
        .or_else(|| volume_format(path).map(DataFormat::Volume))
}

/// Whether a file name is one of the mesh formats.
pub fn is_mesh_file(path: &Path) -> bool {
    mesh_format(path).is_some()
}

/// The error for a file name that is neither a mesh nor a volume format.
pub fn unsupported(path: &Path) -> Error {
    Error::data(
        path,
        "file name",
        format!(
            "unsupported data format; meshes: {}; volumes: {}",
            crate::data::io::SUPPORTED,
            crate::data::io::volume::SUPPORTED
        ),
    )
}

/// Reads a mesh or a volume, choosing by the file name ([`data_format`]).
/// `field` is passed to [`read_volume`](crate::data::io::read_volume)
/// (meshes keep all their fields; the renderer picks one).
pub fn read_dataset(path: &Path, field: &str) -> Result<Dataset> {
    match data_format(path) {
        Some(DataFormat::Mesh(_)) => crate::data::io::read_mesh(path).map(Dataset::Mesh),
        Some(DataFormat::Volume(_)) => {
            crate::data::io::read_volume(path, field).map(Dataset::Volume)
        }
        None => Err(unsupported(path)),
    }
}
