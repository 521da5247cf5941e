//! Typed errors of the library. Every error names the file and, where it can,
//! the line or the field that is wrong, so the user knows what to fix. Only
//! `main.rs` turns them into an exit code.

use std::path::PathBuf;

/// Anything that can go wrong while reading input or rendering.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be opened or read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// A scene (or config) file is not valid: `key` names the offending field.
    #[error("{path}: `{key}`: {msg}")]
    Scene {
        /// The scene file.
        path: PathBuf,
        /// Dotted name of the field, e.g. `camera.up`.
        key: String,
        /// What is wrong and how to fix it.
        msg: String,
    },
    /// A data file is malformed. `location` is a line number, a byte offset
    /// or an XML element, whichever the format allows.
    #[error("{path}: {location}: {msg}")]
    Data {
        /// The data file.
        path: PathBuf,
        /// Where in the file ("line 12", "byte 4096", "<DataArray Name=\"speed\">").
        location: String,
        /// What is wrong.
        msg: String,
    },
    /// The request cannot be rendered (e.g. the field does not exist).
    #[error("{0}")]
    Invalid(String),
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// Shorthand for a data-file error.
    pub fn data(
        path: impl Into<PathBuf>,
        location: impl Into<String>,
        msg: impl Into<String>,
    ) -> Self {
        Error::Data {
            path: path.into(),
            location: location.into(),
            msg: msg.into(),
        }
    }
    /// Shorthand for a scene-file error.
    pub fn scene(path: impl Into<PathBuf>, key: impl Into<String>, msg: impl Into<String>) -> Self {
        Error::Scene {
            path: path.into(),
            key: key.into(),
            msg: msg.into(),
        }
    }
    /// Shorthand for an I/O error on a file.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}
