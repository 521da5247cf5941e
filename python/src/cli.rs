//! The command line inside the module: `python -m pvrsim ARGS` is
//! `pvrsim ARGS` (the same parser, commands, messages and exit codes as the
//! binary's `main`). `transport="processes"` starts its workers this way
//! (`python -m pvrsim worker ...`), so a pip install needs no separate
//! executable: [`worker_argv`] is the program each job passes to the
//! spawner.

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

/// The program a job's `transport="processes"` starts its workers with:
/// this interpreter with `-m pvrsim` (`sys.executable`; `None` when Python
/// cannot name its interpreter, and the job then says it cannot start
/// workers).
pub fn worker_argv(py: Python<'_>) -> PyResult<Option<Vec<std::ffi::OsString>>> {
    let exe: Option<std::path::PathBuf> = py.import("sys")?.getattr("executable")?.extract()?;
    Ok(exe
        .filter(|p| !p.as_os_str().is_empty())
        .map(|p| vec![p.into_os_string(), "-m".into(), "pvrsim".into()]))
}
