//! A whole regular file's bytes for the mesh readers: memory-mapped (read
//! only, private) on Unix, so a large file is parsed in place without a
//! copy, and the pages of a block already decoded can be given back
//! ([`FileBytes::release`]) so the file's bytes and the parsed arrays are
//! not all resident at once. Elsewhere, and for empty files, the bytes are
//! read into memory.
//!
//! The file must not be truncated by another process while it is mapped
//! (as for any memory-mapped reader, the access would fault).

use std::path::Path;

use crate::error::Result;

/// The bytes of a file, mapped or owned; dereferences to `[u8]`.
pub struct FileBytes {
    inner: Inner,
}

enum Inner {
    Owned(Vec<u8>),
    #[cfg(unix)]
    Mapped {
        ptr: *mut libc::c_void,
        len: usize,
    },
}

// The mapping is read-only and owned by this value.
unsafe impl Send for FileBytes {}
unsafe impl Sync for FileBytes {}

/// Files smaller than this are read, not mapped.
const MAP_FROM: u64 = 1 << 20;

impl FileBytes {
    /// Opens a regular file (devices, FIFOs and directories are refused as
    /// by [`super::bounded::read_regular`]) and maps or reads it.
    pub fn open(path: &Path) -> Result<FileBytes> {
        #[cfg(unix)]
        {
            let (f, len) = super::bounded::open_regular(path)?;
            if len >= MAP_FROM && len <= usize::MAX as u64 {
                use std::os::unix::io::AsRawFd;
                // SAFETY: a private read-only mapping of an open regular
                // file of `len` bytes; unmapped on drop.
                let ptr = unsafe {
                    libc::mmap(
                        std::ptr::null_mut(),
                        len as usize,
                        libc::PROT_READ,
                        libc::MAP_PRIVATE,
                        f.as_raw_fd(),
                        0,
                    )
                };
                if ptr != libc::MAP_FAILED {
                    // SAFETY: advice only, on the mapping just made.
                    unsafe { libc::madvise(ptr, len as usize, libc::MADV_SEQUENTIAL) };
                    return Ok(FileBytes {
                        inner: Inner::Mapped {
                            ptr,
                            len: len as usize,
                        },
                    });
                }
            }
        }
        Ok(FileBytes {
            inner: Inner::Owned(super::bounded::read_regular(path)?),
        })
    }

    /// Gives back the resident pages wholly inside `start..end` (a block
    /// already decoded); reading them again re-reads the file. No effect on
    /// read (not mapped) bytes.
    pub fn release(&self, start: usize, end: usize) {
        #[cfg(unix)]
        if let Inner::Mapped { ptr, len } = self.inner {
            let page = 4096usize;
            let a = start.div_ceil(page) * page;
            let b = (end.min(len) / page) * page;
            if b > a {
                // SAFETY: the range lies inside the mapping; for a private
                // read-only file mapping DONTNEED only drops resident pages.
                unsafe {
                    libc::madvise(
                        (ptr as *mut u8).add(a) as *mut libc::c_void,
                        b - a,
                        libc::MADV_DONTNEED,
                    )
                };
            }
        }
        let _ = (start, end);
    }
}

impl std::ops::Deref for FileBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        match &self.inner {
            Inner::Owned(v) => v,
            // SAFETY: the mapping is `len` readable bytes until drop.
            #[cfg(unix)]
            Inner::Mapped { ptr, len } => unsafe {
                std::slice::from_raw_parts(*ptr as *const u8, *len)
            },
        }
    }
}

impl Drop for FileBytes {
    fn drop(&mut self) {
        #[cfg(unix)]
        if let Inner::Mapped { ptr, len } = self.inner {
            // SAFETY: unmaps the mapping made in `open`, no borrow outlives self.
            unsafe { libc::munmap(ptr, len) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapped_and_read_files_give_the_same_bytes() {
        let d = tempfile::tempdir().unwrap();
        for n in [0usize, 10, (3 << 20) + 7] {
            let p = d.path().join(format!("f{n}"));
            let data: Vec<u8> = (0..n).map(|i| (i * 31 % 251) as u8).collect();
            std::fs::write(&p, &data).unwrap();
            let f = FileBytes::open(&p).unwrap();
            assert_eq!(&f[..], &data[..]);
            f.release(0, n);
            assert_eq!(&f[..], &data[..], "released pages read back");
        }
        assert!(FileBytes::open(Path::new("/dev/zero")).is_err());
    }
}
