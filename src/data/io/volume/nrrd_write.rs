//! Writer of attached NRRD files (`.nrrd`, format `NRRD0004`): the header
//! names the type, sizes, `space directions` (diagonal: the spacing) and
//! `space origin`, then a blank line and the samples, little-endian, raw or
//! gzip. [`nrrd::read`](super::nrrd::read) reads it back bit for bit.

use std::io::Write;
use std::path::Path;

use crate::data::{Volume, Voxels};
use crate::error::{Error, Result};

/// The NRRD header text of `v` (ends with the blank line).
pub fn header(v: &Volume, gzip: bool, comment: &str) -> String {
    let ty = match v.voxels {
        Voxels::U8(_) => "uint8",
        Voxels::U16(_) => "uint16",
        Voxels::I16(_) => "int16",
        Voxels::F32(_) => "float",
    };
    let mut s = String::from("NRRD0004\n");
    s += "# Complete NRRD file format specification at:\n# http://teem.sourceforge.net/nrrd/format.html\n";
    for line in comment.lines() {
        s += &format!("# {line}\n");
    }
    s += &format!("content: {}\n", v.field);
    s += &format!("type: {ty}\ndimension: 3\nspace dimension: 3\n");
    s += &format!("sizes: {} {} {}\n", v.dims[0], v.dims[1], v.dims[2]);
    // f64 Display prints the shortest text that parses back to the same value.
    let [sx, sy, sz] = v.spacing;
    s += &format!("space directions: ({sx},0,0) (0,{sy},0) (0,0,{sz})\n");
    s += "kinds: domain domain domain\n";
    if v.voxels.voxel_type().size() > 1 {
        s += "endian: little\n";
    }
    s += &format!("encoding: {}\n", if gzip { "gzip" } else { "raw" });
    let [ox, oy, oz] = v.origin;
    s += &format!("space origin: ({ox},{oy},{oz})\n\n");
    s
}

/// The samples as little-endian bytes.
pub fn sample_bytes(v: &Voxels) -> Vec<u8> {
    match v {
        Voxels::U8(x) => x.clone(),
        Voxels::U16(x) => x.iter().flat_map(|a| a.to_le_bytes()).collect(),
        Voxels::I16(x) => x.iter().flat_map(|a| a.to_le_bytes()).collect(),
        Voxels::F32(x) => x.iter().flat_map(|a| a.to_le_bytes()).collect(),
    }
}

/// Writes `v` as an attached NRRD file; `comment` lines go into the header.
pub fn write_nrrd(v: &Volume, path: &Path, gzip: bool, comment: &str) -> Result<()> {
    let mut out = header(v, gzip, comment).into_bytes();
    let raw = sample_bytes(&v.voxels);
    if gzip {
        let mut e = flate2::write::GzEncoder::new(out, flate2::Compression::default());
        e.write_all(&raw).map_err(|e| Error::io(path, e))?;
        out = e.finish().map_err(|e| Error::io(path, e))?;
    } else {
        out.extend_from_slice(&raw);
    }
    std::fs::write(path, out).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_every_type() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.nrrd");
        for (vox, gz) in [
            (Voxels::U8(vec![1, 2, 3, 4, 5, 6]), false),
            (Voxels::U16(vec![1, 2, 3, 400, 5, 60000]), true),
            (Voxels::I16(vec![-1, 2, 3, 4, -5, 6]), false),
            (Voxels::F32(vec![0.1, 2.0, -3.5, 4e9, 5.0, 6.25]), true),
        ] {
            let v = Volume::new(
                &p,
                [3, 2, 1],
                [0.1, 2.0, 1.0 / 3.0],
                [-16.0, 0.3, 1e-7],
                "s",
                vox,
            )
            .unwrap();
            write_nrrd(&v, &p, gz, "test\nsecond line").unwrap();
            let w = super::super::nrrd::read(&p, "").unwrap();
            assert_eq!(w, v);
        }
    }
}
