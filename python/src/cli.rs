//! The command line inside the module: `python -m pvrsim ARGS` is
//! `pvrsim ARGS` (the same parser, commands, messages and exit codes as the
//! binary's `main`). `transport="processes"` starts its workers this way
//! (`python -m pvrsim worker ...`), so a pip install needs no separate
//! executable: [`set_worker_program`] points the spawner at it.

use clap::Parser;
use pyo3::prelude::*;

/// Runs `pvrsim` with `argv` (without the program name) and returns the
/// exit code, as the binary's `main` does: clap's own output and code for
/// `--help` and usage errors, `error: ...` on stderr and 1 for a failure,
/// 0 on a closed stdout.
#[pyfunction]
pub fn cli_main(py: Python<'_>, argv: Vec<String>) -> i32 {
    py.allow_threads(move || {
        pvrsim::job::output::install_broken_pipe_handler();
        let args = std::iter::once("pvrsim".to_string()).chain(argv);
        let cli = match pvrsim::cli::Cli::try_parse_from(args) {
            Ok(c) => c,
            Err(e) => {
                let _ = e.print();
                return e.exit_code();
            }
        };
        pvrsim::cli::init_logging(cli.verbose);
        match pvrsim::cli::run(cli) {
            Ok(()) => 0,
            Err(e) if pvrsim::job::output::is_broken_pipe(&e) => 0,
            Err(e) => {
                eprint!("{}", pvrsim::cli::error_text(&e));
                1
            }
        }
    })
}

/// Makes `transport="processes"` start its workers as `argv` followed by
/// `worker ...` (the package passes `[sys.executable, "-m", "pvrsim"]`).
#[pyfunction]
pub fn set_worker_program(argv: Vec<std::path::PathBuf>) {
    pvrsim::cluster::remote::spawn::set_worker_program(
        argv.into_iter().map(|p| p.into_os_string()).collect(),
    );
}
