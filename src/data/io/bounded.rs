//! Reading files that a header names, safely: regular files only (no
//! devices, FIFOs, sockets or directories, so `/dev/zero` cannot feed a
//! reader forever), at most a size bound derived from the header, and a
//! relative name resolved under the header's folder.
//!
//! A `data file:` (NRRD) or `variable ... file=` (AVS field) name that is
//! absolute or climbs out with `..` is refused, unless the environment
//! variable [`ALLOW_ENV`] is `1` (for data sets laid out that way on
//! purpose; documented in README.md, "Data files named by a header").

use std::io::Read;
use std::path::{Component, Path, PathBuf};

use crate::error::{Error, Result};

/// Set to `1` to let a header name a data file anywhere (absolute, or
/// outside its folder with `..`).
pub const ALLOW_ENV: &str = "PVRSIM_DATA_FILE_ANYWHERE";

/// Extra bytes a data file may have beyond the header's bound (a trailing
/// newline, padding).
pub const SLACK: u64 = 1 << 20;

/// Refuses what is not a regular file (checked on the opened file).
pub(crate) fn open_regular(path: &Path) -> Result<(std::fs::File, u64)> {
    // Checked before opening (opening a FIFO blocks until a writer comes)
    // and again on the opened file (the name may have changed between).
    let before = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    not_special(path, &before)?;
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // No effect on regular files; a FIFO swapped in after the check
        // does not block the open.
        o.custom_flags(libc::O_NONBLOCK);
    }
    let f = o.open(path).map_err(|e| Error::io(path, e))?;
    let md = f.metadata().map_err(|e| Error::io(path, e))?;
    not_special(path, &md)?;
    Ok((f, md.len()))
}

fn not_special(path: &Path, md: &std::fs::Metadata) -> Result<()> {
    if !md.file_type().is_file() {
        let kind = kind_of(&md.file_type());
        return Err(Error::data(
            path,
            "file",
            format!("is {kind}, not a regular file: pvrsim reads data from regular files only"),
        ));
    }
    Ok(())
}

fn kind_of(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

/// Reads a whole regular file (any size: it is finite).
pub fn read_regular(path: &Path) -> Result<Vec<u8>> {
    let (f, len) = open_regular(path)?;
    let mut out = Vec::with_capacity(len.min(1 << 30) as usize);
    f.take(len)
        .read_to_end(&mut out)
        .map_err(|e| Error::io(path, e))?;
    Ok(out)
}

/// Reads a regular file of at most `limit` bytes; a longer one is an error
/// naming `header` (the file that named it), `location` and both sizes,
/// before anything is read.
pub fn read_limited(path: &Path, limit: u64, header: &Path, location: &str) -> Result<Vec<u8>> {
    let (f, len) = open_regular(path).map_err(|e| match e {
        Error::Data { msg, .. } => Error::data(
            header,
            location,
            format!("data file {}: {msg}", path.display()),
        ),
        Error::Io { source, .. } => Error::data(
            header,
            location,
            format!("cannot read {}: {source}", path.display()),
        ),
        other => other,
    })?;
    if len > limit {
        return Err(Error::data(
            header,
            location,
            format!(
                "data file {} has {len} bytes, more than the {limit} the header's sizes, type and encoding allow",
                path.display()
            ),
        ));
    }
    let mut out = Vec::with_capacity(len as usize);
    f.take(limit + 1)
        .read_to_end(&mut out)
        .map_err(|e| Error::io(path, e))?;
    if out.len() as u64 > limit {
        return Err(Error::data(
            header,
            location,
            format!(
                "data file {} grew past the {limit} bytes the header allows while it was read",
                path.display()
            ),
        ));
    }
    Ok(out)
}

/// `name` (from the header at `header`) resolved under the header's
/// folder. Absolute names and names with `..` are refused unless
/// [`ALLOW_ENV`] is `1`.
pub fn resolve_under(header: &Path, name: &str, location: &str) -> Result<PathBuf> {
    let base = header.parent().unwrap_or(Path::new(""));
    let p = Path::new(name);
    let allowed = std::env::var(ALLOW_ENV).is_ok_and(|v| v == "1");
    if !allowed {
        let escapes = p.is_absolute()
            || p.components().any(|c| {
                matches!(
                    c,
                    Component::ParentDir | Component::RootDir | Component::Prefix(_)
                )
            });
        if escapes {
            return Err(Error::data(
                header,
                location,
                format!(
                    "\"{name}\" is outside the header's folder (absolute, or with `..`): a data file must be \
                     in the header's folder or below it (set {ALLOW_ENV}=1 to allow any path)"
                ),
            ));
        }
    }
    Ok(base.join(p))
}

/// A bound on a data file's bytes for `payload` bytes of samples stored
/// with `encoding` after `skip` bytes: raw as is, compressed streams (which
/// can be slightly larger than their contents) with 1/64 more, hex three
/// characters a byte, ASCII up to 32 characters a sample of `sample_bytes`;
/// plus [`SLACK`].
pub fn bound(payload: u64, skip: u64, encoding: Stored, sample_bytes: u64) -> u64 {
    let body = match encoding {
        Stored::Raw => payload,
        Stored::Compressed => payload.saturating_add(payload / 64),
        Stored::Hex => payload.saturating_mul(3),
        Stored::Ascii => (payload / sample_bytes.max(1)).saturating_mul(32),
    };
    body.saturating_add(skip).saturating_add(SLACK)
}

/// How a data file stores its samples, for [`bound`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stored {
    /// The bytes themselves.
    Raw,
    /// A gzip/zlib stream.
    Compressed,
    /// Two hex digits a byte, whitespace between.
    Hex,
    /// Numbers as text.
    Ascii,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_directories_are_refused() {
        let e = read_regular(Path::new("/dev/zero"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("character device"), "{e}");
        let d = tempfile::tempdir().unwrap();
        let e = read_regular(d.path()).unwrap_err().to_string();
        assert!(e.contains("directory") || e.contains("regular"), "{e}");
    }

    #[test]
    fn escaping_names_are_refused() {
        let h = Path::new("/data/x/head.nhdr");
        assert!(resolve_under(h, "../../etc/passwd", "l").is_err());
        assert!(resolve_under(h, "/dev/zero", "l").is_err());
        assert_eq!(
            resolve_under(h, "sub/a.raw", "l").unwrap(),
            Path::new("/data/x/sub/a.raw")
        );
    }

    #[test]
    fn a_file_over_the_bound_is_refused_before_reading() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("big.raw");
        std::fs::write(&p, vec![0u8; 100]).unwrap();
        let e = read_limited(&p, 10, Path::new("h.nhdr"), "line 3 (`data file`)")
            .unwrap_err()
            .to_string();
        assert!(e.contains("h.nhdr") && e.contains("100 bytes"), "{e}");
        assert_eq!(
            read_limited(&p, 100, Path::new("h"), "l").unwrap().len(),
            100
        );
    }
}
