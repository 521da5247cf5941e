//! Python keyword values to options by flag name, and the option tables
//! that the package's docstrings and keyword checks are built from (so no
//! option, default or help text is written twice).

use clap::{Args, Command};
use pvrsim::job::args::by_name::ParamValue;
use pvrsim::job::{ClusterJob, RenderJob};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString};

/// Keyword arguments as options by flag name. `True` is the bare flag,
/// `False` leaves it out, numbers and strings are the flag's value (the
/// package turns paths into strings and drops `None` before this).
pub fn options(py: Python<'_>, kw: &Bound<'_, PyList>) -> PyResult<Vec<(String, ParamValue)>> {
    let mut out = Vec::with_capacity(kw.len());
    for item in kw.iter() {
        let (name, v): (String, Bound<'_, PyAny>) = item.extract()?;
        let value = if v.is_instance_of::<PyBool>() {
            ParamValue::Bool(v.extract()?)
        } else if v.is_instance_of::<PyInt>() {
            ParamValue::Int(v.extract().map_err(|_| {
                crate::errors::raise(
                    py,
                    "OptionError",
                    format!("{name}={v}: the integer does not fit in 64 bits"),
                    &[],
                )
            })?)
        } else if v.is_instance_of::<PyFloat>() {
            let x: f64 = v.extract()?;
            if !x.is_finite() {
                return Err(crate::errors::raise(
                    py,
                    "OptionError",
                    format!("{name}={x}: NaN and infinite values are not allowed"),
                    &[],
                ));
            }
            ParamValue::Float(x)
        } else if v.is_instance_of::<PyString>() {
            ParamValue::Str(v.extract()?)
        } else {
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "{name}: expected a bool, a number or a string, got {}",
                v.get_type().name()?
            )));
        };
        out.push((name, value));
    }
    Ok(out)
}

/// The clap definition of `command` (`"render"`, `"cluster"` or `"view"`).
fn definition(command: &str) -> PyResult<Command> {
    Ok(match command {
        "render" => RenderJob::augment_args(Command::new("pvrsim render")),
        "cluster" => ClusterJob::augment_args(Command::new("pvrsim cluster")),
        "view" => pvrsim::view::ViewArgs::augment_args(Command::new("pvrsim view")),
        other => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "no option table for {other:?}"
            )))
        }
    })
}

/// Every option of `pvrsim render` / `pvrsim cluster` as a list of dicts:
/// `name` (the keyword), `flag`, `help`, `default` (text or `None`),
/// `choices`, `flag_only` (a switch: pass `True`), `hidden`, `positional`.
#[pyfunction]
pub fn option_table<'py>(py: Python<'py>, command: &str) -> PyResult<Bound<'py, PyList>> {
    let cmd = definition(command)?;
    let out = PyList::empty(py);
    for a in cmd.get_arguments() {
        let id = a.get_id().as_str();
        if id == "help" || id == "version" {
            continue;
        }
        let d = PyDict::new(py);
        let name = a.get_long().map_or(id.to_string(), |l| l.replace('-', "_"));
        d.set_item("name", name)?;
        d.set_item("flag", a.get_long().map(|l| format!("--{l}")))?;
        let help = a
            .get_long_help()
            .or_else(|| a.get_help())
            .map(|h| h.to_string())
            .unwrap_or_default();
        d.set_item("help", help)?;
        let defaults: Vec<String> = a
            .get_default_values()
            .iter()
            .map(|v| v.to_string_lossy().into_owned())
            .collect();
        d.set_item(
            "default",
            if defaults.is_empty() {
                None
            } else {
                Some(defaults.join(","))
            },
        )?;
        let choices: Vec<String> = a
            .get_possible_values()
            .iter()
            .filter(|p| !p.is_hide_set())
            .map(|p| p.get_name().to_string())
            .collect();
        d.set_item("choices", choices)?;
        d.set_item("flag_only", !a.get_action().takes_values())?;
        d.set_item("hidden", a.is_hide_set())?;
        d.set_item("positional", a.is_positional())?;
        d.set_item(
            "value_name",
            a.get_value_names()
                .and_then(|v| v.first())
                .map(|s| s.to_string()),
        )?;
        out.append(d)?;
    }
    Ok(out)
}
