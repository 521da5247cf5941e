//! `pvrsim.view`: the live viewer ([`pvrsim::view::Viewer`], the server
//! `pvrsim view` runs) started from Python. Opened from `pvrsim view`'s
//! options by flag name (parsed and checked as the command line does);
//! the server and its render loop run on threads of their own until
//! `close()`.

use pvrsim::job::args::by_name::from_options;
use pvrsim::job::JobError;
use pvrsim::view::{ViewArgs, Viewer};
use pyo3::prelude::*;
use pyo3::types::PyList;

use crate::errors::job_error;

/// See the module docs.
#[pyclass(module = "pvrsim._native")]
pub struct NativeViewer {
    inner: Option<Viewer>,
    url: String,
}

#[pymethods]
impl NativeViewer {
    /// Starts a viewer: `options` as `pvrsim view`'s (the scene first).
    #[new]
    fn new(py: Python<'_>, options: &Bound<'_, PyList>) -> PyResult<Self> {
        let opts = crate::values::options(py, options)?;
        let err = |e: JobError| job_error(py, e, &opts);
        let mut args: ViewArgs = from_options("pvrsim view", &["scene"], &opts)
            .map_err(|e| err(JobError::Options(Box::new(e))))?;
        args.worker_argv = crate::cli::worker_argv(py)?;
        args.check().map_err(|e| err(JobError::Invalid(e)))?;
        let v = py
            .allow_threads(|| Viewer::start(&args))
            .map_err(|e| err(JobError::Failed(e)))?;
        Ok(NativeViewer {
            url: v.url.clone(),
            inner: Some(v),
        })
    }

    /// `http://127.0.0.1:PORT/?token=TOKEN`.
    #[getter]
    fn url(&self) -> String {
        self.url.clone()
    }

    /// Whether the server still runs.
    fn running(&self) -> bool {
        self.inner.is_some()
    }

    /// Stops the server, its render loop and a cluster session (worker
    /// processes exit). Idempotent.
    fn close(&mut self, py: Python<'_>) -> PyResult<()> {
        if let Some(v) = self.inner.take() {
            py.allow_threads(|| v.close())
                .map_err(|e| job_error(py, JobError::Failed(e), &[]))?;
        }
        Ok(())
    }
}
