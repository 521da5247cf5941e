//! The three jobs: `render` ([`RenderJob`]), `cluster` ([`ClusterJob`])
//! and `sweep` (`pvrsim::experiment::run_sweep`, the config-file sweep of
//! `pvrsim sweep`). Each builds its job from options by flag name, checks
//! it and the output paths it was given (as the command line does, before
//! any work), runs it off the GIL ([`crate::interrupt`]) and hands back
//! arrays and JSON text; the files it was asked for (`output`, `stats`,
//! `report`, `trace`, `timeline`) are written as the command line writes
//! them.

use std::path::{Path, PathBuf};

use anyhow::Context;
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3};
use pvrsim::image::Image;
use pvrsim::job::args::by_name::ParamValue;
use pvrsim::job::output::{prepare_output, OutputKind};
use pvrsim::job::{ClusterJob, ClusterResult, JobError, RenderJob};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::errors::job_error;

/// The image as (H, W, 4) uint8: RGB exactly as the PNG the command line
/// writes (`Image::to_rgb8`), A the opacity rounded the same way.
fn rgba8<'py>(py: Python<'py>, image: &Image) -> Bound<'py, PyArray3<u8>> {
    let rgb = image.to_rgb8();
    let mut out = Vec::with_capacity(image.pixels.len() * 4);
    for (p, c) in image.pixels.iter().zip(rgb.chunks_exact(3)) {
        out.extend_from_slice(c);
        out.push((p[3].clamp(0.0, 1.0) * 255.0).round() as u8);
    }
    Array3::from_shape_vec((image.height as usize, image.width as usize, 4), out)
        .expect("H x W x 4")
        .into_pyarray(py)
}

/// The value of option `name`, if the caller gave it.
fn given<'a>(options: &'a [(String, ParamValue)], name: &str) -> Option<&'a ParamValue> {
    options.iter().find(|(k, _)| k == name).map(|(_, v)| v)
}

/// Checks the output paths the caller named (as the command line checks
/// `-o`, `--stats`, ...) before any work.
fn prepare(
    options: &[(String, ParamValue)],
    outputs: &[(&str, &str, Option<&Path>, OutputKind)],
) -> Result<(), JobError> {
    for (name, flag, path, kind) in outputs {
        if let (Some(_), Some(p)) = (given(options, name), path) {
            prepare_output(flag, p, *kind).map_err(JobError::Invalid)?;
        }
    }
    Ok(())
}

fn json<T: serde::Serialize>(v: &T) -> String {
    serde_json::to_string(v).expect("serializes")
}

/// `pvrsim render` with `options` (a list of `(keyword, value)`): a dict of
/// `image`, `stats` (JSON text), `summary` (the lines the command prints),
/// `warnings`.
#[pyfunction]
pub fn render<'py>(py: Python<'py>, options: &Bound<'py, PyList>) -> PyResult<Bound<'py, PyDict>> {
    let opts = crate::values::options(py, options)?;
    let err = |e: JobError| job_error(py, e, &opts);
    let job = RenderJob::from_options(&opts).map_err(err)?;
    let warnings = job.check().map_err(err)?;
    prepare(
        &opts,
        &[
            ("output", "-o", Some(&job.output), OutputKind::Png),
            ("stats", "--stats", job.stats.as_deref(), OutputKind::Json),
        ],
    )
    .map_err(err)?;
    let names = opts_names(&opts);
    let out = crate::interrupt::run(py, None, move || {
        let out = job.run()?;
        write_render_outputs(&job, &out, &names)?;
        Ok::<_, JobError>(out)
    });
    let out = out?.map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("image", rgba8(py, &out.image))?;
    d.set_item("stats", json(&out.stats))?;
    d.set_item("summary", out.summary.clone())?;
    d.set_item("warnings", warnings)?;
    Ok(d)
}

fn opts_names(o: &[(String, ParamValue)]) -> Vec<String> {
    o.iter().map(|(k, _)| k.clone()).collect()
}

/// Writes `-o` and `--stats` when the caller named them.
fn write_render_outputs(
    job: &RenderJob,
    out: &pvrsim::job::RenderOutcome,
    given: &[String],
) -> Result<(), JobError> {
    let w = || -> anyhow::Result<()> {
        if given.iter().any(|k| k == "output") {
            out.image.save_png(&job.output)?;
        }
        if let (true, Some(p)) = (given.iter().any(|k| k == "stats"), &job.stats) {
            std::fs::write(p, serde_json::to_string_pretty(&out.stats)?)
                .with_context(|| format!("cannot write {}", p.display()))?;
        }
        Ok(())
    };
    w().map_err(JobError::Failed)
}

/// A timeline row: node, activity, start and end (s), bytes, peer.
type TraceRow<'a> = (u32, &'a str, f64, f64, u64, Option<u32>);

/// What a cluster run hands back besides its image.
struct ClusterOut {
    result: ClusterResult,
    warnings: Vec<String>,
}

/// Writes `-o`, `--report`, `--trace`, `--timeline` when the caller named them.
fn write_cluster_outputs(
    job: &ClusterJob,
    r: &ClusterResult,
    given: &[String],
) -> Result<(), JobError> {
    let has = |k: &str| given.iter().any(|g| g == k);
    let w = || -> anyhow::Result<()> {
        // Every frame with a `%d` pattern in `output`, and the movie: the
        // command line's own writer.
        let output = has("output").then_some(job.output.as_path());
        pvrsim::job::series::output::write_series_images(output, &job.series, &r.images(), false)?;
        if let ClusterResult::Mesh(frames) = r {
            if let Some(last) = frames.last() {
                pvrsim::job::series::output::write_series_csv(&job.series, &last.report)?;
            }
        }
        if let (true, Some(p)) = (has("report"), &job.report) {
            std::fs::write(p, serde_json::to_string_pretty(&r.report_json())?)
                .with_context(|| format!("cannot write {}", p.display()))?;
        }
        let (trace, ranks) = r.trace();
        if let (true, Some(p)) = (has("trace"), &job.trace) {
            let f = std::fs::File::create(p)
                .with_context(|| format!("cannot write {}", p.display()))?;
            trace.write_chrome_json(std::io::BufWriter::new(f))?;
        }
        if let (true, Some(p)) = (has("timeline"), &job.timeline) {
            pvrsim::cluster::timeline::draw(&trace, ranks, p)?;
        }
        Ok(())
    };
    w().map_err(JobError::Failed)
}

/// `pvrsim cluster` with `options`: a dict of `image`, `images` (every
/// frame's), `report` (JSON text
/// of the last frame's report), `frames` (every frame's report, JSON
/// text), `trace` (rows `(node, activity, start_s, end_s, bytes, peer)`),
/// `summary` (the text the command prints), `warnings`.
#[pyfunction]
pub fn cluster<'py>(py: Python<'py>, options: &Bound<'py, PyList>) -> PyResult<Bound<'py, PyDict>> {
    let opts = crate::values::options(py, options)?;
    let err = |e: JobError| job_error(py, e, &opts);
    let mut job = ClusterJob::from_options(&opts).map_err(err)?;
    if let Some(argv) = crate::cli::worker_argv(py)? {
        job.net
            .set_worker_argv(argv)
            .map_err(|e| err(JobError::Failed(e)))?;
    }
    let warnings = job.check().map_err(err)?;
    prepare(
        &opts,
        &[
            ("output", "-o", Some(&job.output), OutputKind::Png),
            (
                "report",
                "--report",
                job.report.as_deref(),
                OutputKind::Json,
            ),
            (
                "series_csv",
                "--series-csv",
                job.series.series_csv.as_deref(),
                OutputKind::Csv,
            ),
            ("trace", "--trace", job.trace.as_deref(), OutputKind::Json),
            (
                "timeline",
                "--timeline",
                job.timeline.as_deref(),
                OutputKind::Png,
            ),
        ],
    )
    .map_err(err)?;
    let names = opts_names(&opts);
    let out = crate::interrupt::run(py, None, move || {
        let result = job.run()?;
        write_cluster_outputs(&job, &result, &names)?;
        Ok::<_, JobError>(ClusterOut { result, warnings })
    });
    let out = out?.map_err(err)?;
    cluster_dict(py, &out.result, &out.warnings)
}

/// A cluster result as the dict [`cluster`] returns (also each frame of a
/// [`crate::session::NativeSession`]).
pub fn cluster_dict<'py>(
    py: Python<'py>,
    r: &ClusterResult,
    warnings: &[String],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("image", rgba8(py, r.image()))?;
    d.set_item(
        "images",
        r.images()
            .into_iter()
            .map(|i| rgba8(py, i))
            .collect::<Vec<_>>(),
    )?;
    d.set_item("report", json(&r.report_json()))?;
    d.set_item(
        "frames",
        r.frame_reports_json().iter().map(json).collect::<Vec<_>>(),
    )?;
    let (trace, ranks) = r.trace();
    let rows: Vec<TraceRow<'_>> = trace
        .events
        .iter()
        .map(|e| {
            (
                e.node.0,
                e.kind.name(),
                e.start,
                e.end,
                e.bytes,
                e.peer.map(|p| p.0),
            )
        })
        .collect();
    d.set_item("trace", rows)?;
    d.set_item("ranks", ranks)?;
    d.set_item("summary", r.summary())?;
    d.set_item("warnings", warnings.to_vec())?;
    Ok(d)
}

/// `pvrsim sweep CONFIG --out OUT [--force] [--only K=V ...]`: runs the
/// sweep (results.csv, summary.md, plots under OUT/NAME/); `tick` is
/// called while it runs (the package prints new rows of results.csv from
/// it when asked for progress). A dict of `csv`, `out_dir`, `summary`,
/// `warnings`, `missing`, `runs_selected`, `runs_executed`,
/// `runs_skipped`, `runs_failed`.
#[pyfunction]
#[pyo3(signature = (config, out, force, only, allow_missing, tick=None))]
pub fn sweep<'py>(
    py: Python<'py>,
    config: PathBuf,
    out: PathBuf,
    force: bool,
    only: Vec<(String, String)>,
    allow_missing: bool,
    tick: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let config_path = config.clone();
    let opts = pvrsim::experiment::SweepOptions {
        config,
        out,
        force,
        dry_run: false,
        only,
        allow_missing,
        progress: false,
        lines: false,
    };
    let r = crate::interrupt::run(py, tick.as_ref(), move || {
        pvrsim::experiment::run_sweep(&opts)
    })?;
    let r = r.map_err(|e| sweep_error(py, e, &config_path))?;
    let d = PyDict::new(py);
    d.set_item("csv", r.csv.display().to_string())?;
    d.set_item("out_dir", r.out_dir.display().to_string())?;
    d.set_item("summary", r.summary_text)?;
    d.set_item("warnings", r.warnings)?;
    d.set_item(
        "missing",
        r.missing
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>(),
    )?;
    d.set_item("runs_selected", r.runs_selected)?;
    d.set_item("runs_executed", r.runs_executed)?;
    d.set_item("runs_skipped", r.runs_skipped)?;
    d.set_item("runs_failed", r.runs_failed)?;
    Ok(d)
}

/// A sweep's error: a file it names (the config, a scene, data) is a
/// `FileError`, a point the validation refuses (its message names the
/// option's flag) an `OptionError`; anything else is about the config
/// file, a `FileError` naming it.
fn sweep_error(py: Python<'_>, e: anyhow::Error, config: &Path) -> PyErr {
    let msg = pvrsim::job::error_line(&e);
    if crate::errors::names_a_file(&e) {
        crate::errors::library_error(py, e)
    } else if msg.contains(" --") || msg.contains("sweep point") {
        crate::errors::raise(py, "OptionError", msg, &[])
    } else {
        let p = config.display().to_string();
        let p = p.into_pyobject(py).expect("a str").into_any().unbind();
        crate::errors::raise(py, "FileError", msg, &[("filename", p)])
    }
}

/// The name of the sweep config at `config` (its results go to OUT/NAME/).
#[pyfunction]
pub fn sweep_name(py: Python<'_>, config: PathBuf) -> PyResult<String> {
    pvrsim::experiment::config::Plan::load(&config)
        .map(|p| p.name)
        .map_err(|e| sweep_error(py, e, &config))
}

/// A JSON object (a sweep config given as a dict) as TOML text.
#[pyfunction]
pub fn toml_from_json(py: Python<'_>, text: &str) -> PyResult<String> {
    let v: toml::Value = serde_json::from_str(text)
        .map_err(|e| crate::errors::raise(py, "OptionError", format!("sweep config: {e}"), &[]))?;
    toml::to_string(&v)
        .map_err(|e| crate::errors::raise(py, "OptionError", format!("sweep config: {e}"), &[]))
}
