//! Everything the command line writes, in one place:
//!
//! - **Broken pipe** ([`install_broken_pipe_handler`], [`is_broken_pipe`]):
//!   `pvrsim ... | head -1` closes stdout early. Rust ignores `SIGPIPE`, so
//!   `println!` panics on the closed pipe; the panic hook installed once in
//!   `main` turns exactly that panic into a normal stop (exit 0), and `main`
//!   does the same for an error whose cause is an `io::ErrorKind::BrokenPipe`.
//!   Every command, present and future, gets this without doing anything.
//! - **Output paths** ([`prepare_output`]): every file a command writes
//!   (`-o`, `--stats`, `--report`, `--timeline`, `--trace`, ...) is checked
//!   *before* any work starts: the extension must fit the format, at most one
//!   missing directory level is created (and the user is told), and the
//!   directory must be writable. A typo therefore fails in milliseconds, not
//!   after a long render, and never creates a tree of directories.
//!   A file that exists is replaced with a note (`note: replacing FILE`);
//!   the commands whose outputs other runs read (`scene`, `generate`,
//!   `partition`, `calibrate`'s shipped profiles) refuse it first without
//!   `--force`: the one overwrite policy, in README.md.
//! - **Warnings** ([`warn`]): one format, on stderr, so that stdout stays
//!   machine-readable.

use std::io::ErrorKind;
use std::path::{Path, PathBuf};

use anyhow::Context;

/// The kind of file an option writes; decides the accepted extensions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// A PNG image (`.png`).
    Png,
    /// JSON (`.json`).
    Json,
    /// TOML (`.toml`).
    Toml,
    /// CSV (`.csv`).
    Csv,
    /// An attached NRRD volume (`.nrrd`).
    Nrrd,
    /// A partitioned mesh (`.pvtu`, its `.vtu` pieces beside it).
    Pvtu,
}

impl OutputKind {
    /// Accepted extensions (lower case, without the dot).
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            OutputKind::Png => &["png"],
            OutputKind::Json => &["json"],
            OutputKind::Toml => &["toml"],
            OutputKind::Csv => &["csv"],
            OutputKind::Nrrd => &["nrrd"],
            OutputKind::Pvtu => &["pvtu"],
        }
    }

    fn what(self) -> &'static str {
        match self {
            OutputKind::Png => "a PNG image",
            OutputKind::Json => "JSON",
            OutputKind::Toml => "TOML",
            OutputKind::Csv => "CSV",
            OutputKind::Nrrd => "an attached NRRD volume",
            OutputKind::Pvtu => "a partitioned mesh (the .pvtu; its .vtu pieces go beside it)",
        }
    }
}

/// Prints `warning: MSG` on stderr.
pub fn warn(msg: impl std::fmt::Display) {
    eprintln!("warning: {msg}");
}

/// Warns when `image` holds no volume at all (every pixel's alpha is 0):
/// the camera sees nothing, or no cell is visible. `detail` says what the
/// renderer counted (e.g. "0 cells projected on screen").
pub fn warn_if_empty(image: &crate::image::Image, detail: &str) -> bool {
    let empty = image.pixels.iter().all(|p| p[3] <= 0.0);
    if empty {
        warn(format!(
            "the image is empty: every pixel is the background ({detail}); check the camera (eye, target, height or fov_y_deg), the image size and the transfer function's opacities"
        ));
    }
    empty
}

/// Checks that `option` (e.g. `-o`, `--stats`) may write `kind` to `path`,
/// before any work: the extension fits `kind`; the parent directory exists,
/// or only its last level is missing (then it is created and a note is
/// printed on stderr); the directory is writable, and so is the file if it
/// exists. Returns the path unchanged.
pub fn prepare_output(option: &str, path: &Path, kind: OutputKind) -> anyhow::Result<PathBuf> {
    let shown = path.display();
    anyhow::ensure!(
        !path.as_os_str().is_empty(),
        "{option}: the output path is empty"
    );
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    if !kind.extensions().contains(&ext.as_str()) {
        anyhow::bail!(
            "{option} {shown}: this option writes {} (use a file name ending in .{}){}",
            kind.what(),
            kind.extensions()[0],
            if ext.is_empty() {
                String::new()
            } else {
                format!("; .{ext} is not supported")
            }
        );
    }
    anyhow::ensure!(
        !path.is_dir(),
        "{option} {shown}: cannot write: is a directory, not a file name"
    );
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !parent.is_dir() {
        anyhow::ensure!(
            !parent.exists(),
            "{option} {shown}: cannot write: {} exists and is not a directory",
            parent.display()
        );
        let grand = match parent.parent() {
            Some(g) if !g.as_os_str().is_empty() => g.to_path_buf(),
            _ => PathBuf::from("."),
        };
        anyhow::ensure!(
            grand.is_dir(),
            "{option} {shown}: cannot write: directory {} does not exist (pvrsim creates at most one missing level; create {} first)",
            parent.display(),
            grand.display()
        );
        std::fs::create_dir(&parent).with_context(|| {
            format!(
                "{option} {shown}: cannot write: cannot create directory {}",
                parent.display()
            )
        })?;
        eprintln!("note: created directory {} for {option}", parent.display());
    }
    if path.exists() {
        std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .with_context(|| {
                format!("{option} {shown}: cannot write: the file exists and is not writable")
            })?;
        // The one overwrite policy (README, "Command-line behaviour"): a
        // result is replaced, never in silence; commands whose outputs are
        // other runs' inputs refuse before this without --force.
        eprintln!("note: replacing {shown} ({option})");
    } else {
        // Create and remove the file itself: the only sure test of writability.
        std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
            .with_context(|| format!("{option} {shown}: cannot write the file"))?;
        let _ = std::fs::remove_file(path);
    }
    Ok(path.to_path_buf())
}

/// Makes sure directory `dir` (an option's value, e.g. `--out-dir`) exists:
/// creates it if only its last level is missing (and says so); refuses to
/// create a tree.
pub fn prepare_dir(option: &str, dir: &Path) -> anyhow::Result<()> {
    if dir.is_dir() {
        return Ok(());
    }
    anyhow::ensure!(
        !dir.exists(),
        "{option} {}: exists and is not a directory",
        dir.display()
    );
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    anyhow::ensure!(
        parent.is_dir(),
        "{option} {}: {} does not exist (pvrsim creates at most one missing level; create {} first)",
        dir.display(),
        parent.display(),
        parent.display()
    );
    std::fs::create_dir(dir)
        .with_context(|| format!("{option}: cannot create {}", dir.display()))?;
    eprintln!("note: created directory {} for {option}", dir.display());
    Ok(())
}

/// Whether `e` (or any cause) is an I/O error of kind `BrokenPipe`.
pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == ErrorKind::BrokenPipe)
    })
}

/// Installs a panic hook that ends the process with exit code 0 when the
/// panic is `println!` failing on a closed stdout (a reader such as `head`
/// stopped reading: a normal stop), and otherwise behaves as the default hook.
pub fn install_broken_pipe_handler() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.contains("failed printing to stdout") && msg.contains("Broken pipe") {
            std::process::exit(0);
        }
        default(info);
    }));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extension_is_checked() {
        let d = tempfile::tempdir().unwrap();
        let e = prepare_output("-o", &d.path().join("x.jpg"), OutputKind::Png).unwrap_err();
        assert!(e.to_string().contains(".jpg is not supported"), "{e}");
        assert!(prepare_output("-o", &d.path().join("x.PNG"), OutputKind::Png).is_ok());
        assert!(
            !d.path().join("x.PNG").exists(),
            "the probe file is removed"
        );
    }

    #[test]
    fn one_missing_level_is_created_two_are_refused() {
        let d = tempfile::tempdir().unwrap();
        let one = d.path().join("a/x.json");
        prepare_output("--stats", &one, OutputKind::Json).unwrap();
        assert!(d.path().join("a").is_dir());
        let two = d.path().join("b/c/x.json");
        let e = prepare_output("--stats", &two, OutputKind::Json).unwrap_err();
        assert!(e.to_string().contains("at most one missing level"), "{e}");
        assert!(!d.path().join("b").exists());
    }

    #[test]
    fn broken_pipe_is_recognised_in_the_chain() {
        let io = std::io::Error::new(ErrorKind::BrokenPipe, "gone");
        let e = anyhow::Error::new(io).context("writing the table");
        assert!(is_broken_pipe(&e));
        assert!(!is_broken_pipe(&anyhow::anyhow!("other")));
    }
}
