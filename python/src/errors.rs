//! Errors to exceptions. The classes live in `pvrsim._errors` (Python, so
//! that they can inherit from two built-ins: `OptionError(Error,
//! ValueError)`, `FileError(Error, OSError)`); this file picks the class
//! and keeps the command line's message.
//!
//! | what failed | class |
//! | --- | --- |
//! | an option does not parse, or validation refuses it (`JobError::Options`, `JobError::Invalid`) | `OptionError` (a `ValueError`) |
//! | an unknown option | `UnknownOptionError` (an `OptionError` and a `TypeError`) |
//! | arrays passed from Python are malformed | `DataError` (a `ValueError`) |
//! | a file is missing, unreadable or malformed (`pvrsim::Error::{Io, Data, Scene}`, `std::io::Error`) | `FileError` (an `OSError`; `.filename` is the file) |
//! | anything else while running (a transport, memory, a panic) | `RunError` (a `RuntimeError`) |

use std::path::{Path, PathBuf};

use pvrsim::job::args::by_name::{clap_message, flag, ParamValue};
use pvrsim::job::JobError;
use pyo3::prelude::*;

/// An exception of class `name` from `pvrsim._errors` with `msg`, and the
/// attributes `attrs` set on it.
pub fn raise(py: Python<'_>, name: &str, msg: String, attrs: &[(&str, PyObject)]) -> PyErr {
    let make = || -> PyResult<PyErr> {
        let cls = py.import("pvrsim._errors")?.getattr(name)?;
        let e = cls.call1((msg.clone(),))?;
        for (k, v) in attrs {
            e.setattr(*k, v)?;
        }
        Ok(PyErr::from_value(e))
    };
    make().unwrap_or_else(|e| e)
}

/// A `DataError`: arrays handed in from Python are malformed.
pub fn data_error(py: Python<'_>, msg: String) -> PyErr {
    raise(py, "DataError", msg, &[])
}

/// The file a library error names, if it names one.
fn file_of(e: &anyhow::Error) -> Option<Option<PathBuf>> {
    for c in e.chain() {
        if let Some(x) = c.downcast_ref::<pvrsim::error::Error>() {
            return match x {
                pvrsim::error::Error::Io { path, .. }
                | pvrsim::error::Error::Data { path, .. }
                | pvrsim::error::Error::Scene { path, .. } => Some(Some(path.clone())),
                pvrsim::error::Error::Invalid(_) => None,
            };
        }
        if c.downcast_ref::<std::io::Error>().is_some() {
            return Some(None);
        }
    }
    None
}

/// Whether a library error names a file (or is an I/O error).
pub fn names_a_file(e: &anyhow::Error) -> bool {
    file_of(e).is_some()
}

/// A library error (reading data, a scene) as `FileError` when it names a
/// file, else `RunError`; the message is the whole chain, as the command
/// line prints it on one line.
pub fn library_error(py: Python<'_>, e: anyhow::Error) -> PyErr {
    let msg = pvrsim::job::error_line(&e);
    match file_of(&e) {
        Some(path) => {
            let attrs: Vec<(&str, PyObject)> = path
                .map(|p| vec![("filename", path_obj(py, &p))])
                .unwrap_or_default();
            raise(py, "FileError", msg, &attrs)
        }
        None => raise(py, "RunError", msg, &[]),
    }
}

fn path_obj(py: Python<'_>, p: &Path) -> PyObject {
    p.display()
        .to_string()
        .into_pyobject(py)
        .expect("a str")
        .into_any()
        .unbind()
}

/// The keywords among `options` whose flag a message names (`ert=1.5` for
/// a message about `--ert`), longest flag first so `--ert-table` is not
/// taken for `--ert`.
fn named_keywords(msg: &str, options: &[(String, ParamValue)]) -> Vec<String> {
    let mut named: Vec<&(String, ParamValue)> = options
        .iter()
        .filter(|(k, _)| {
            let f = flag(k);
            msg.match_indices(&f).any(|(i, _)| {
                let next = msg[i + f.len()..].chars().next();
                !matches!(next, Some(c) if c.is_alphanumeric() || c == '-')
            })
        })
        .collect();
    named.sort_by_key(|(k, _)| std::cmp::Reverse(k.len()));
    named
        .into_iter()
        .map(|(k, v)| match v {
            ParamValue::Str(s) => format!("{k}={s:?}"),
            _ => format!("{k}={v}"),
        })
        .collect()
}

/// A job's error as the package's exception. `options` are the keywords
/// the job was built from, to name the offending one(s).
pub fn job_error(py: Python<'_>, e: JobError, options: &[(String, ParamValue)]) -> PyErr {
    let (class, msg) = match e {
        JobError::Options(c) => {
            let class = match c.kind() {
                clap::error::ErrorKind::UnknownArgument => "UnknownOptionError",
                _ => "OptionError",
            };
            (class, clap_message(&c))
        }
        JobError::Invalid(e) => ("OptionError", pvrsim::job::error_line(&e)),
        JobError::Failed(e) => return library_error(py, e),
    };
    let named = named_keywords(&msg, options);
    // `ert=1.5: --ert 1.5: ...`: the keyword as the caller wrote it, then
    // the command line's message.
    let full = match named.first() {
        Some(first) => format!("{first}: {msg}"),
        None => msg,
    };
    let option = named
        .first()
        .map(|n| n.split('=').next().unwrap_or(n).to_string());
    let attrs: Vec<(&str, PyObject)> = option
        .map(|o| {
            vec![(
                "option",
                o.into_pyobject(py).expect("a str").into_any().unbind(),
            )]
        })
        .unwrap_or_default();
    raise(py, class, full, &attrs)
}

/// Runs `f`, turning a panic into `RunError` (the quick calls that do not
/// go through [`crate::interrupt::run`]).
pub fn guard<T>(py: Python<'_>, f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => Err(raise(
            py,
            "RunError",
            format!(
                "internal error: pvrsim panicked: {} (please report it)",
                panic_text(p.as_ref())
            ),
            &[],
        )),
    }
}

/// A panic payload's message.
pub fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<String>()
        .cloned()
        .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "(no message)".into())
}
