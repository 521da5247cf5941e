//! Mesh readers, one file per format, and the legacy VTK writer; volume
//! readers and writers are in [`volume`] ([`read_volume`]), and
//! [`read_dataset`](crate::data::read_dataset) reads either kind.
//!
//! [`read_mesh`] picks the reader by file extension ([`mesh_format`], the one
//! place that knows the mesh formats; [`crate::data::data_format`] adds the
//! volumes):
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

use crate::data::locality::{make_local, Renumbering};
use crate::data::TetMesh;
use crate::error::{Error, Result};

pub use volume::read_volume;
pub use vtk_write::write_vtk_legacy;

/// The extensions [`read_mesh`] understands, for messages.
pub const SUPPORTED: &str =
    ".vtk (VTK legacy), .vtu (VTK XML UnstructuredGrid), .pvtu (its partitioned form), .inp (AVS UCD ASCII)";

/// The mesh formats, as recognised from a file name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// VTK legacy `UNSTRUCTURED_GRID` (`.vtk`).
    VtkLegacy,
    /// VTK XML `UnstructuredGrid` (`.vtu`).
    Vtu,
    /// VTK XML `PUnstructuredGrid` (`.pvtu`), `.vtu` pieces.
    Pvtu,
    /// AVS UCD ASCII (`.inp`).
    AvsUcd,
}

/// The mesh format a file name asks for (by its extension,
/// case-insensitive), or `None`.
pub fn mesh_format(path: &Path) -> Option<MeshFormat> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "vtk" => Some(MeshFormat::VtkLegacy),
        "vtu" => Some(MeshFormat::Vtu),
        "pvtu" => Some(MeshFormat::Pvtu),
        "inp" => Some(MeshFormat::AvsUcd),
        _ => None,
    }
}

/// Reads a tetrahedral mesh, choosing the format by the file's extension
/// (case-insensitive), and validates it ([`TetMesh::validate`]: indices in
/// range, coordinates and field values finite, field lengths right);
/// renumbered along a space-filling curve when the file's numbering is
/// scattered ([`load_mesh`]).
pub fn read_mesh(path: &Path) -> Result<TetMesh> {
    Ok(read_mesh_with_pieces(path)?.0)
}

/// [`read_mesh`], with the tetrahedra of each piece of a `.pvtu` (`None`
/// for the other formats): the union holds the pieces' cells in turn.
pub fn read_mesh_with_pieces(path: &Path) -> Result<(TetMesh, Option<Vec<u64>>)> {
    let l = load_mesh(path)?;
    Ok((l.mesh, l.pieces))
}

/// A mesh as the load path gives it ([`load_mesh`]).
#[derive(Debug)]
pub struct LoadedMesh {
    /// The mesh, renumbered when the file's numbering was not local.
    pub mesh: TetMesh,
    /// A `.pvtu`'s tetrahedra per piece, in turn (`None` for the other formats).
    pub pieces: Option<Vec<u64>>,
    /// The sampled locality of the file's numbering
    /// ([`locality`](crate::data::locality::locality)).
    pub file_locality: f64,
    /// How the mesh was renumbered (for each new index, the file's), or
    /// `None` when it keeps the file's numbering.
    pub renumbering: Option<Renumbering>,
}

/// The one load path of meshes: reads the file by its format
/// ([`mesh_format`]), validates it ([`TetMesh::validate`], whose errors
/// name the file's own indices), then renumbers vertices and cells along a
/// space-filling curve when the file's numbering is scattered
/// ([`make_local`]; a `.pvtu`'s cells stay in their pieces).
pub fn load_mesh(path: &Path) -> Result<LoadedMesh> {
    let (mut mesh, pieces) = read_in_file_order(path)?;
    let t = std::time::Instant::now();
    let (file_locality, renumbering) = make_local(&mut mesh, pieces.as_deref());
    if renumbering.is_some() {
        tracing::info!(
            "{}: numbering not local ({:.1} % of sampled cells), renumbered along a Morton curve in {:.3} s",
            path.display(),
            100.0 * file_locality,
            t.elapsed().as_secs_f64()
        );
    }
    Ok(LoadedMesh {
        mesh,
        pieces,
        file_locality,
        renumbering,
    })
}

/// Reads a mesh as [`load_mesh`] does, but renumbered by `like` (another
/// load's renumbering: a series' time step numbered as the scene's mesh)
/// instead of its own; in the file's numbering when `like` is `None` or
/// does not fit the mesh's counts (then a topology check refuses it).
pub fn read_mesh_like(path: &Path, like: Option<&Renumbering>) -> Result<TetMesh> {
    let (mut mesh, _) = read_in_file_order(path)?;
    if let Some(r) = like {
        if r.vertices.len() == mesh.points.len() && r.cells.len() == mesh.tets.len() {
            crate::data::locality::apply(&mut mesh, r);
        }
    }
    Ok(mesh)
}

/// The mesh in the file's numbering, validated, with a `.pvtu`'s pieces.
fn read_in_file_order(path: &Path) -> Result<(TetMesh, Option<Vec<u64>>)> {
    let mut pieces = None;
    let mesh = match mesh_format(path) {
        Some(MeshFormat::VtkLegacy) => vtk_legacy::read(path)?,
        Some(MeshFormat::Vtu) => vtu::read(path)?,
        Some(MeshFormat::Pvtu) => {
            let (m, p) = pvtu::read_with_pieces(path)?;
            pieces = Some(p);
            m
        }
        Some(MeshFormat::AvsUcd) => avs_ucd::read(path)?,
        None => {
            let ext = path.extension().map(|e| e.to_string_lossy().to_lowercase());
            return Err(Error::data(
                path,
                "file name",
                format!(
                    "unsupported mesh format (extension {}); supported: {SUPPORTED}",
                    ext.map_or("missing".to_string(), |e| format!("\".{e}\""))
                ),
            ));
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
