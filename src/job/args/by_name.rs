//! Options by flag name: the one mapping from `name = value` pairs (a job
//! file, a sweep's `fixed` and `vary` tables) to a job. A parameter `name`
//! is the option `--name` (underscores become dashes), a `true` boolean the
//! bare flag, `false` nothing; the job's own clap definition parses the
//! result, so every option a command has is reachable under its name, with
//! the command line's defaults, ranges and messages.

use clap::{Args, FromArgMatches};
use serde::{Deserialize, Serialize};

/// The option a parameter becomes: `ert_table` -> `--ert-table`.
pub fn flag(name: &str) -> String {
    format!("--{}", name.replace('_', "-"))
}

/// Parses a command line (without program and subcommand names) into the
/// options `T` of the command `name` (e.g. `"pvrsim render"`, as clap's
/// messages name it).
pub fn parse<T: Args + FromArgMatches>(
    name: &'static str,
    argv: &[String],
) -> Result<T, clap::Error> {
    let cmd = T::augment_args(clap::Command::new(name).no_binary_name(true));
    let m = cmd.try_get_matches_from(argv)?;
    T::from_arg_matches(&m)
}

/// One value of a run parameter, as written in the config.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ParamValue {
    /// `true` becomes a bare flag, `false` omits it.
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A floating-point number.
    Float(f64),
    /// A string (an enum value, a path, ...).
    Str(String),
}

impl ParamValue {
    /// Converts a TOML scalar; lists, tables and dates are refused with a
    /// message naming `key`.
    pub fn from_toml(v: &toml::Value, key: &str) -> Result<Self, String> {
        match v {
            toml::Value::Boolean(b) => Ok(Self::Bool(*b)),
            toml::Value::Integer(i) => Ok(Self::Int(*i)),
            toml::Value::Float(f) if f.is_finite() => Ok(Self::Float(*f)),
            toml::Value::Float(_) => Err(format!("{key}: NaN and infinite values are not allowed")),
            toml::Value::String(s) => Ok(Self::Str(s.clone())),
            toml::Value::Datetime(_) => Err(format!("{key}: a date is not a parameter value")),
            toml::Value::Array(_) => Err(format!("{key}: expected a single value, found a list")),
            toml::Value::Table(_) => Err(format!("{key}: expected a single value, found a table")),
        }
    }

    /// The value as a number, if it is one.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Self::Int(i) => Some(*i as f64),
            Self::Float(f) => Some(*f),
            _ => None,
        }
    }
}

impl From<bool> for ParamValue {
    fn from(b: bool) -> Self {
        Self::Bool(b)
    }
}

impl From<i64> for ParamValue {
    fn from(i: i64) -> Self {
        Self::Int(i)
    }
}

impl From<i32> for ParamValue {
    fn from(i: i32) -> Self {
        Self::Int(i.into())
    }
}

impl From<u32> for ParamValue {
    fn from(i: u32) -> Self {
        Self::Int(i.into())
    }
}

impl From<f64> for ParamValue {
    fn from(x: f64) -> Self {
        Self::Float(x)
    }
}

impl From<&str> for ParamValue {
    fn from(s: &str) -> Self {
        Self::Str(s.to_string())
    }
}

impl From<String> for ParamValue {
    fn from(s: String) -> Self {
        Self::Str(s)
    }
}

impl std::fmt::Display for ParamValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Bool(b) => write!(f, "{b}"),
            Self::Int(i) => write!(f, "{i}"),
            Self::Float(x) => write!(f, "{x}"),
            Self::Str(s) => f.write_str(s),
        }
    }
}

/// The command line of `options`: the `positional` ones first (in that
/// order), then `--name=value` per option, a bare `--name` for `true`,
/// nothing for `false`. `text` writes a value (e.g. resolving a path).
pub fn argv(
    positional: &[&str],
    options: &[(String, ParamValue)],
    text: impl Fn(&str, &ParamValue) -> String,
) -> Vec<String> {
    let mut out = Vec::new();
    for p in positional {
        if let Some((k, v)) = options.iter().find(|(k, _)| k == p) {
            out.push(text(k, v));
        }
    }
    for (k, v) in options {
        if positional.contains(&k.as_str()) {
            continue;
        }
        match v {
            ParamValue::Bool(true) => out.push(flag(k)),
            ParamValue::Bool(false) => {}
            _ => out.push(format!("{}={}", flag(k), text(k, v))),
        }
    }
    out
}

/// Parses options by flag name (a job file's table) into the options `T`
/// of the command `name`; `positional` names the positional ones.
pub fn from_options<T: Args + FromArgMatches>(
    name: &'static str,
    positional: &[&str],
    options: &[(String, ParamValue)],
) -> Result<T, clap::Error> {
    parse(name, &argv(positional, options, |_, v| v.to_string()))
}

/// Clap's message without the usage block, on one line.
pub fn clap_message(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let text = text.split("\nUsage:").next().unwrap_or(&text);
    let text = text.trim().trim_start_matches("error:").trim();
    let mut out = String::new();
    let lines = text.lines().map(str::trim).filter(|l| {
        !l.is_empty() && !l.starts_with("For more information") && !l.starts_with("tip: to pass")
    });
    for l in lines {
        if !out.is_empty() {
            out.push_str(if out.ends_with(':') { " " } else { "; " });
        }
        out.push_str(l);
    }
    out
}
