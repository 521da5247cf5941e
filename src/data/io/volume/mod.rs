//! Regular-grid (volume) readers, one file per format, and the NRRD writer.
//!
//! [`read_volume`] picks the reader by file name (case-insensitive):
//!
//! | name ends in | format | module |
//! | --- | --- | --- |
//! | `.nrrd`, `.nhdr` | NRRD, attached or detached; raw, gzip, ascii, hex | [`nrrd`] |
//!
//! Every reader returns a [`Volume`] in its compact voxel type with an
//! axis-aligned placement (negative directions are flipped, see
//! [`placement`]); every error is an [`Error`](crate::Error) naming the file
//! and the header line, field or byte offset at fault, and no reader
//! allocates what a header claims before checking it against the file.

pub mod nrrd;
pub mod placement;
pub mod samples;

use std::path::Path;

use crate::data::Volume;
use crate::error::{Error, Result};

/// The file-name endings [`read_volume`] understands, for messages.
pub const SUPPORTED: &str = ".nrrd / .nhdr (NRRD)";

/// The volume formats, as recognised from a file name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VolumeFormat {
    /// NRRD, attached (`.nrrd`) or detached (`.nhdr`).
    Nrrd,
}

/// The volume format a file name asks for, or `None`.
pub fn volume_format(path: &Path) -> Option<VolumeFormat> {
    let name = path.file_name()?.to_str()?.to_ascii_lowercase();
    if name.ends_with(".nrrd") || name.ends_with(".nhdr") {
        Some(VolumeFormat::Nrrd)
    } else {
        None
    }
}

/// Reads a regular grid, choosing the format by the file name. `field`
/// selects the array in formats that name several (an error lists them
/// when it is absent); in single-scalar formats (NRRD, NIfTI, AVS field)
/// it only names the volume's scalar, and may be empty.
pub fn read_volume(path: &Path, field: &str) -> Result<Volume> {
    match volume_format(path) {
        Some(VolumeFormat::Nrrd) => nrrd::read(path, field),
        None => Err(Error::data(
            path,
            "file name",
            format!("unsupported volume format; supported: {SUPPORTED}"),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_by_name() {
        assert_eq!(
            volume_format(Path::new("a/B.NHDR")),
            Some(VolumeFormat::Nrrd)
        );
        assert_eq!(volume_format(Path::new("a.vtk")), None);
        let e = read_volume(Path::new("x.png"), "").unwrap_err().to_string();
        assert!(e.contains("x.png") && e.contains(".nrrd"), "{e}");
    }
}
