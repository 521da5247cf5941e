//! `pvrsim._native`: the compiled half of the `pvrsim` Python package. It
//! is thin over the job layer: options go in by flag name
//! ([`pvrsim::job::args::by_name`]: the command line's names, defaults, parsing
//! and validation), jobs run on a thread of their own while the calling
//! thread waits without the GIL and polls for Ctrl-C ([`interrupt`]),
//! results come back as numpy arrays and JSON text. The public API, its
//! docstrings and the pandas conversions are the Python package's
//! (`python/pysrc/pvrsim`); nothing here is meant to be called directly.
//!
//! - [`errors`]: `JobError` and the library's errors to the package's
//!   exception classes;
//! - [`interrupt`]: running a job off the GIL, interruptible;
//! - [`values`]: Python values to [`pvrsim::job::args::by_name::ParamValue`],
//!   and the option tables that `help()` shows;
//! - [`arrays`]: numpy arrays to and from flat vectors;
//! - [`mesh`], [`volume`]: data in memory, read with the crate's readers,
//!   validated by the crate's checks, written with its writers;
//! - [`scene`]: loading, checking and fitting scenes;
//! - [`jobs`]: render, cluster and sweep;
//! - [`view`]: the live viewer's server (`pvrsim.view`);
//! - [`cli`]: the command line itself (`python -m pvrsim`), which is also
//!   how `transport="processes"` starts its workers.

use pyo3::prelude::*;

mod arrays;
mod cli;
mod errors;
mod interrupt;
mod jobs;
mod mesh;
mod scene;
mod session;
mod values;
mod view;
mod volume;

/// The compiled module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<mesh::NativeMesh>()?;
    m.add_class::<volume::NativeVolume>()?;
    m.add_class::<session::NativeSession>()?;
    m.add_class::<view::NativeViewer>()?;
    m.add_function(wrap_pyfunction!(values::option_table, m)?)?;
    m.add_function(wrap_pyfunction!(scene::check_scene, m)?)?;
    m.add_function(wrap_pyfunction!(scene::rewrite_scene, m)?)?;
    m.add_function(wrap_pyfunction!(scene::fit_scene, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::render, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::cluster, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::sweep, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::sweep_name, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::toml_from_json, m)?)?;
    m.add_function(wrap_pyfunction!(cli::cli_main, m)?)?;
    m.add_function(wrap_pyfunction!(interrupt::jobs_running, m)?)?;
    Ok(())
}
