//! Mesh readers, one file per format, and the legacy VTK writer; volume
//! readers and writers are in [`volume`] ([`read_volume`]), and
//! [`read_dataset`](crate::data::read_dataset) reads either kind.
//!
//! [`read_mesh`] picks the reader by file extension:
//!
//! | extension | format | module |
//! | --- | --- | --- |
//! | `.vtk` | VTK legacy `UNSTRUCTURED_GRID`, ASCII or BINARY, classic and 5.1 cell layout | [`vtk_legacy`] |
//! | `.vtu` | VTK XML `UnstructuredGrid`: ascii, inline base64, appended raw/base64, zlib | [`vtu`] |
//! | `.inp` | AVS UCD ASCII | [`avs_ucd`] |
//! | `.pvtu` | VTK XML `PUnstructuredGrid`: `.vtu` pieces, read in parallel and joined | [`pvtu`] |
//!
//! Every reader returns tetrahedra (other 3D linear cells are decomposed, see
//! [`decompose`]) and point-data fields; cell data is skipped. Every error is
//! an [`Error`] naming the file and the line, byte offset, XML
//! element or cell at fault.

pub mod avs_ucd;
pub mod bounded;
pub mod decompose;
pub mod mapped;
pub mod numeric;
pub mod pvtu;
pub mod volume;
pub mod vtk_legacy;
pub mod vtk_write;
pub mod vtu;

use std::path::Path;

use crate::data::TetMesh;
use crate::error::{Error, Result};

pub use volume::read_volume;
pub use vtk_write::write_vtk_legacy;

/// The extensions [`read_mesh`] understands, for messages.
pub const SUPPORTED: &str =
    ".vtk (VTK legacy), .vtu (VTK XML UnstructuredGrid), .pvtu (its partitioned form), .inp (AVS UCD ASCII)";

/// Reads a tetrahedral mesh, choosing the format by the file's extension
/// (case-insensitive), and validates it ([`TetMesh::validate`]: indices in
/// range, coordinates and field values finite, field lengths right).
pub fn read_mesh(path: &Path) -> Result<TetMesh> {
    Ok(read_mesh_with_pieces(path)?.0)
}

/// [`read_mesh`], with the tetrahedra of each piece of a `.pvtu` (`None`
/// for the other formats): the union holds the pieces' cells in turn.
pub fn read_mesh_with_pieces(path: &Path) -> Result<(TetMesh, Option<Vec<u64>>)> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mut pieces = None;
    let mesh = match ext.as_deref() {
        Some("vtk") => vtk_legacy::read(path)?,
        Some("vtu") => vtu::read(path)?,
        Some("pvtu") => {
            let (m, p) = pvtu::read_with_pieces(path)?;
            pieces = Some(p);
            m
        }
        Some("inp") => avs_ucd::read(path)?,
        _ => {
            return Err(Error::data(
                path,
                "file name",
                format!(
                    "unsupported mesh format (extension {}); supported: {SUPPORTED}",
                    ext.map_or("missing".to_string(), |e| format!("\".{e}\""))
                ),
            ))
        }
    };
    mesh.validate(path)?;
    Ok((mesh, pieces))
}

/// Reads a whole regular file (a device, FIFO or directory is refused),
/// mapping the failure to [`Error::Io`].
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    bounded::read_regular(path)
}

/// 1-based line number of byte `offset` in `data`.
pub(crate) fn line_of(data: &[u8], offset: usize) -> usize {
    data[..offset.min(data.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}
