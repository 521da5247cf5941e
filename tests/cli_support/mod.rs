//! Helpers of the command-line tests (`tests/cli_options.rs`,
//! `tests/cli_outputs.rs`, `tests/pieces.rs`, `tests/pieces_workers.rs`):
//! run the binary, read its output, copy VTK's pieces.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The binary under test.
pub const EXE: &str = env!("CARGO_BIN_EXE_pvrsim");

/// A file in tests/data.
pub fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The bundled aorta-small view B scene (100x100).
pub fn small_b() -> String {
    data("aorta-small-view-b.toml").display().to_string()
}

/// Runs `pvrsim ARGS` in `dir`.
pub fn run_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(EXE)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run pvrsim")
}

/// stdout and stderr as text.
pub fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Asserts a failure with exit code 1 whose stderr holds every `needle`.
pub fn fails_with(o: &Output, needles: &[&str]) {
    let (out, err) = text(o);
    assert_eq!(o.status.code(), Some(1), "stdout: {out}\nstderr: {err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in stderr: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

/// A JSON file.
pub fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Runs `pvrsim ARGS` (data files outside a scene's folder refused, the
/// default): (success, stderr). A panic fails the test.
pub fn pvrsim(args: &[&str]) -> (bool, String) {
    let out = Command::new(EXE)
        .args(args)
        .env_remove("PVRSIM_DATA_FILE_ANYWHERE")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!err.contains("panicked"), "{err}");
    (out.status.success(), err)
}

/// VTK 9.7.2's `enc` (`raw`, `zlib`) pieces of the small aorta
/// (`tests/data/pieces/`) copied into `dir`: `a.pvtu` and its four `.vtu`.
pub fn copy_vtk_pieces(enc: &str, dir: &Path) {
    for k in 0..4 {
        let n = format!("aorta-small-{enc}_{k}.vtu");
        std::fs::copy(data(&format!("pieces/{n}")), dir.join(&n)).unwrap();
    }
    std::fs::copy(
        data(&format!("pieces/aorta-small-{enc}.pvtu")),
        dir.join("a.pvtu"),
    )
    .unwrap();
}
