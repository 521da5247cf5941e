//! `pvrsim.Session`: a persistent cluster session ([`pvrsim::job::Session`])
//! held by Python. Opened from `pvrsim cluster`'s options (checked as the
//! command line checks them); each `render` is one frame on the same nodes,
//! with the camera and transfer function given as scene tables (JSON text
//! from the package), returned as the dict [`crate::jobs::cluster`]
//! returns.

use pvrsim::job::{ClusterJob, ClusterResult, FrameRequest, JobError, Session};
use pvrsim::scene::Scene;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::errors::job_error;

/// See the module docs.
#[pyclass(module = "pvrsim._native")]
pub struct NativeSession {
    inner: Option<Session>,
    warnings: Vec<String>,
}

#[pymethods]
impl NativeSession {
    /// Opens a session: `options` as for `cluster` (the scene first).
    #[new]
    fn new(py: Python<'_>, options: &Bound<'_, PyList>) -> PyResult<Self> {
        let opts = crate::values::options(py, options)?;
        let err = |e: JobError| job_error(py, e, &opts);
        let mut job = ClusterJob::from_options(&opts).map_err(err)?;
        if let Some(argv) = crate::cli::worker_argv(py)? {
            job.net
                .set_worker_argv(argv)
                .map_err(|e| err(JobError::Failed(e)))?;
        }
        let warnings = job.check().map_err(err)?;
        let s = py.allow_threads(|| Session::open(&job)).map_err(err)?;
        Ok(NativeSession {
            inner: Some(s),
            warnings,
        })
    }

    /// One frame: `changes` is JSON text of scene tables to replace
    /// (`camera`, `transfer`), `step` a time step, `size` `(width, height)`.
    #[pyo3(signature = (changes=None, step=None, size=None))]
    fn render<'py>(
        &mut self,
        py: Python<'py>,
        changes: Option<&str>,
        step: Option<usize>,
        size: Option<(u32, u32)>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let err = |e: JobError| job_error(py, e, &[]);
        let s = self.inner.as_mut().ok_or_else(|| {
            crate::errors::raise(py, "OptionError", "the session is closed".to_string(), &[])
        })?;
        let mut req = FrameRequest {
            step,
            size,
            ..Default::default()
        };
        if let Some(c) = changes {
            let scene = changed_scene(s.scene(), c).map_err(|e| err(JobError::Invalid(e)))?;
            req.camera = Some(scene.camera);
            req.transfer = Some(scene.transfer);
        }
        let out = py.allow_threads(|| s.frame(&req)).map_err(err)?;
        crate::jobs::cluster_dict(py, &ClusterResult::Mesh(vec![out]), &self.warnings)
    }

    /// The session's scene as TOML (its data path as the scene names it).
    fn scene_toml(&self) -> Option<String> {
        self.inner
            .as_ref()
            .map(|s| s.scene().to_toml(&s.scene().data.path.to_string_lossy()))
    }

    /// Frames rendered so far.
    fn frames(&self) -> usize {
        self.inner.as_ref().map_or(0, Session::frames)
    }

    /// Ends the nodes (worker processes exit). Idempotent.
    fn close(&mut self, py: Python<'_>) -> PyResult<()> {
        if let Some(s) = self.inner.take() {
            py.allow_threads(|| s.close())
                .map_err(|e| job_error(py, e, &[]))?;
        }
        Ok(())
    }
}

/// The session's scene with the tables of `changes` (JSON object text:
/// `camera`, `transfer`) in place of its own, parsed and checked as a
/// scene file is.
fn changed_scene(scene: &Scene, changes: &str) -> anyhow::Result<Scene> {
    let changes: serde_json::Value = serde_json::from_str(changes)?;
    let obj = changes
        .as_object()
        .ok_or_else(|| anyhow::anyhow!("the frame's changes must be a table"))?;
    let text = scene.to_toml(&scene.data.path.to_string_lossy());
    let mut doc: toml::Table = toml::from_str(&text)?;
    for (k, v) in obj {
        anyhow::ensure!(
            matches!(k.as_str(), "camera" | "transfer"),
            "render: `{k}` cannot change in a session (camera and transfer can; a time step is \
             step=, the image size is size=)"
        );
        let v: toml::Value =
            serde_json::from_value(v.clone()).map_err(|e| anyhow::anyhow!("render: `{k}`: {e}"))?;
        doc.insert(k.clone(), v);
    }
    let text = toml::to_string(&doc)?;
    Scene::parse(&text, std::path::Path::new("(the session's scene)"))
        .map_err(|e| anyhow::anyhow!("{e}"))
}
