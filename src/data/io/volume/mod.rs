//! Regular-grid (volume) readers, one file per format, and the NRRD writer.
//!
//! [`read_volume`] picks the reader by file name (case-insensitive):
//!
//! | name ends in | format | module |
//! | --- | --- | --- |
//! | `.nrrd`, `.nhdr` | NRRD, attached or detached; raw, gzip, ascii, hex | [`nrrd`] |
//! | `.nii`, `.nii.gz` | NIfTI-1 single file, sform/qform axis-aligned | [`nifti`] |
//! | `.vti` | VTK XML ImageData: ascii, base64, appended, zlib | [`vti`] |
//! | `.fld` | AVS field, uniform, embedded or external binary | [`avs_field`] |
//!
//! Every reader returns a [`Volume`] in its compact voxel type with an
//! axis-aligned placement (negative directions are flipped, see
//! [`placement`]); every error is an [`Error`] naming the file
//! and the header line, field or byte offset at fault, and no reader
//! allocates what a header claims before checking it against the file.

pub mod avs_field;
pub mod nifti;
pub mod nrrd;
pub mod nrrd_write;
pub mod placement;
pub mod samples;
pub mod vti;

pub use nrrd_write::write_nrrd;

use std::path::Path;

use crate::data::Volume;
use crate::error::{Error, Result};

/// The file-name endings [`read_volume`] understands, for messages.
pub const SUPPORTED: &str =
    ".nrrd / .nhdr (NRRD), .nii / .nii.gz (NIfTI-1), .vti (VTK XML ImageData), .fld (AVS field)";

/// The volume formats, as recognised from a file name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VolumeFormat {
    /// NRRD, attached (`.nrrd`) or detached (`.nhdr`).
    Nrrd,
    /// NIfTI-1, `.nii` or `.nii.gz`.
    Nifti,
    /// VTK XML ImageData.
    Vti,
    /// AVS field.
    AvsField,
}

/// The volume format a file name asks for, or `None`.
pub fn volume_format(path: &Path) -> Option<VolumeFormat> {
    let name = path.file_name()?.to_str()?.to_ascii_lowercase();
    if name.ends_with(".nrrd") || name.ends_with(".nhdr") {
        Some(VolumeFormat::Nrrd)
    } else if name.ends_with(".nii") || name.ends_with(".nii.gz") {
        Some(VolumeFormat::Nifti)
    } else if name.ends_with(".vti") {
        Some(VolumeFormat::Vti)
    } else if name.ends_with(".fld") {
        Some(VolumeFormat::AvsField)
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
        Some(VolumeFormat::Nifti) => nifti::read(path, field),
        Some(VolumeFormat::Vti) => vti::read(path, field),
        Some(VolumeFormat::AvsField) => avs_field::read(path, field),
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
