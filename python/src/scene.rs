//! Scenes: checked by the scene contract's parser ([`Scene::parse`]),
//! written back by [`Scene::to_toml`], fitted to data in memory by the
//! code of `pvrsim scene` (`pvrsim::scene::fit::scene_text`).

use std::path::{Path, PathBuf};

use pvrsim::cli::scene::SceneArgs;
use pvrsim::job::args::by_name::ParamValue;
use pvrsim::scene::fit::{scene_text, FitSpec, SceneSource};
use pvrsim::scene::Scene;
use pyo3::prelude::*;
use pyo3::types::PyDict;

fn parse(py: Python<'_>, text: &str, path: &Path) -> PyResult<Scene> {
    crate::errors::guard(py, || {
        Scene::parse(text, path).map_err(|e| crate::errors::library_error(py, e.into()))
    })
}

/// Checks scene `text` (read from, or to be written at, `path`): a dict of
/// `data_path` (resolved against the scene's folder), `field`, `width`,
/// `height`.
#[pyfunction]
pub fn check_scene<'py>(
    py: Python<'py>,
    text: &str,
    path: PathBuf,
) -> PyResult<Bound<'py, PyDict>> {
    let s = parse(py, text, &path)?;
    let d = PyDict::new(py);
    d.set_item("data_path", s.data.path.display().to_string())?;
    d.set_item("field", s.data.field.clone())?;
    d.set_item("width", s.image.width)?;
    d.set_item("height", s.image.height)?;
    Ok(d)
}

/// Scene `text` (at `path`) written again in the contract's format with
/// `data_path` as its data path (comments are not kept).
#[pyfunction]
pub fn rewrite_scene(
    py: Python<'_>,
    text: &str,
    path: PathBuf,
    data_path: &str,
) -> PyResult<String> {
    Ok(parse(py, text, &path)?.to_toml(data_path))
}

/// `pvrsim scene`'s fitted scene for data in memory (a `NativeMesh` or a
/// `NativeVolume`), naming the data file `data_name` (relative to the
/// scene's folder); `options` are the keywords (field, view, size,
/// perspective) for messages.
#[pyfunction]
#[pyo3(signature = (data, data_name, field, view, width, height, perspective))]
#[allow(clippy::too_many_arguments)]
pub fn fit_scene(
    py: Python<'_>,
    data: &Bound<'_, PyAny>,
    data_name: &str,
    field: Option<String>,
    view: String,
    width: u32,
    height: u32,
    perspective: Option<f64>,
) -> PyResult<String> {
    let mut options: Vec<(String, ParamValue)> = vec![
        ("view".into(), ParamValue::Str(view.clone())),
        ("size".into(), ParamValue::Str(format!("{width}x{height}"))),
    ];
    if let Some(f) = &field {
        options.push(("field".into(), ParamValue::Str(f.clone())));
    }
    if let Some(p) = perspective {
        options.push(("perspective".into(), ParamValue::Float(p)));
    }
    let args = SceneArgs {
        data: PathBuf::from(data_name),
        output: PathBuf::from("scene.toml"),
        field,
        view,
        perspective,
        size: format!("{width}x{height}"),
        force: false,
    };
    let invalid = |e: anyhow::Error| {
        crate::errors::job_error(py, pvrsim::job::JobError::Invalid(e), &options)
    };
    pvrsim::job::validate::check(&args).map_err(invalid)?;
    let src: &dyn SceneSource = if let Ok(m) = data.downcast::<crate::mesh::NativeMesh>() {
        m.get().mesh.as_ref()
    } else if let Ok(v) = data.downcast::<crate::volume::NativeVolume>() {
        v.get().volume.as_ref()
    } else {
        return Err(pyo3::exceptions::PyTypeError::new_err(
            "Scene.fit takes a pvrsim.Mesh or a pvrsim.Volume",
        ));
    };
    let spec = FitSpec {
        data: args.data.clone(),
        output: args.output.clone(),
        field: args.field.clone(),
        view: args.view.clone(),
        size: (width, height),
        perspective: args.perspective,
    };
    let text = crate::errors::guard(py, || scene_text(&spec, src).map_err(invalid))?;
    // The scene must parse as the renderers will read it.
    parse(py, &text, Path::new("scene.toml"))?;
    Ok(text)
}
