//! Small helpers several test files share: the shared data folder
//! (`../shared/data`, optional) and a read of bad bytes that must fail with
//! a message naming the file.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// `../shared/data/NAME`, or `None` (saying the test is skipped) when the
/// shared data folder does not hold it.
pub fn shared(name: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(name);
    if p.exists() {
        Some(p)
    } else {
        eprintln!(
            "SKIPPED: {} is absent (needs the shared data folder)",
            p.display()
        );
        None
    }
}

/// Writes `bytes` to a temporary file named `name`, reads it with `read`
/// and asserts the read fails with a message that starts with the file's
/// path and contains every needle; returns the message.
pub fn expect_err<T>(
    name: &str,
    bytes: &[u8],
    needles: &[&str],
    read: impl Fn(&Path) -> Result<T, pvrsim::Error>,
) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    let path = p.display().to_string();
    let msg = read(&p)
        .err()
        .unwrap_or_else(|| panic!("{name}: expected an error for {needles:?}"))
        .to_string();
    assert!(
        msg.starts_with(&path),
        "message does not name the file: {msg}"
    );
    eprintln!("{msg}");
    for n in needles {
        assert!(msg.contains(n), "message lacks {n:?}: {msg}");
    }
    msg
}
