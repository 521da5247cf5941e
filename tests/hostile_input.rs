//! Issue 26, files and options: each hostile input of the issue is replayed
//! and must end with exit code 1 within a few seconds, no panic or abort,
//! and a message naming the file, key, option or worker. (The worker's
//! network cases are in tests/hostile_network.rs.)

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod cli_support;
use cli_support::*;

/// Runs `pvrsim ARGS` in `dir`, killing it after `limit`; asserts it ends
/// within the limit with exit code 1, no panic, no allocation abort, and a
/// stderr holding every `needle`. Returns stderr.
fn refused_within(dir: &Path, args: &[&str], limit: Duration, needles: &[&str]) -> String {
    let t = Instant::now();
    let mut child = Command::new(EXE)
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if t.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("pvrsim {args:?} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let err = reader.join().unwrap();
    assert_eq!(status.code(), Some(1), "pvrsim {args:?}: {status:?}\n{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!err.contains("memory allocation"), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in stderr of {args:?}: {err}");
    }
    err
}

const FEW: Duration = Duration::from_secs(10);

fn nhdr(dir: &Path, name: &str, data_file: &str) -> String {
    let p = dir.join(name);
    std::fs::write(
        &p,
        format!(
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: {data_file}\n"
        ),
    )
    .unwrap();
    p.display().to_string()
}

#[test]
fn nrrd_data_file_dev_zero_is_refused_at_once() {
    let d = tempfile::tempdir().unwrap();
    let h = nhdr(d.path(), "zero.nhdr", "/dev/zero");
    refused_within(d.path(), &["info", &h], FEW, &["zero.nhdr", "data file"]);
    // Through a symbolic link inside the folder: not a regular file.
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("/dev/zero", d.path().join("z.raw")).unwrap();
        let h = nhdr(d.path(), "link.nhdr", "z.raw");
        refused_within(
            d.path(),
            &["info", &h],
            FEW,
            &["link.nhdr", "character device"],
        );
    }
}

#[test]
fn nrrd_data_file_outside_the_folder_is_refused_before_reading() {
    let d = tempfile::tempdir().unwrap();
    let h = nhdr(d.path(), "up.nhdr", "../../../../etc/passwd");
    refused_within(
        d.path(),
        &["info", &h],
        FEW,
        &["up.nhdr", "data file", "outside the header's folder"],
    );
}

#[test]
fn nrrd_data_file_larger_than_the_header_allows_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let f = std::fs::File::create(d.path().join("big.raw")).unwrap();
    f.set_len(64 << 20).unwrap(); // sparse: 64 MiB for a 4x4x4 header
    let h = nhdr(d.path(), "big.nhdr", "big.raw");
    refused_within(d.path(), &["info", &h], FEW, &["big.nhdr", "more than the"]);
}

#[test]
fn a_directory_or_fifo_as_the_scene_data_is_refused() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir(d.path().join("dir.nrrd")).unwrap();
    refused_within(d.path(), &["info", "dir.nrrd"], FEW, &["dir.nrrd"]);
    #[cfg(unix)]
    {
        let fifo = d.path().join("fifo.nrrd");
        let ok = Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success();
        assert!(ok);
        refused_within(
            d.path(),
            &["info", "fifo.nrrd"],
            FEW,
            &["fifo.nrrd", "FIFO"],
        );
    }
}
