//! The sweep config file's tables as written ([`RawConfig`], deserialized
//! with unknown keys refused), before validation.

use serde::Deserialize;

/// The config file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawConfig {
    /// Name of the sweep; results go to `OUT/NAME/`.
    pub name: String,
    /// Free text, copied into summary.md.
    #[serde(default)]
    pub description: Option<String>,
    /// The pvrsim subcommand each run executes (default `render`).
    #[serde(default)]
    pub command: Option<String>,
    /// Scene file, relative to the config file (a parameter named `scene`).
    #[serde(default)]
    pub scene: Option<String>,
    /// Files that must exist (relative to the config file).
    #[serde(default)]
    pub requires: Vec<String>,
    /// How to make generated data that `requires` (or a scene) names:
    /// `[[make]] files = [...]`, `run = "generate ..."` (a pvrsim command
    /// line, paths relative to the config file).
    #[serde(default)]
    pub make: Vec<RawMake>,
    /// Runs per sweep point (default 1).
    #[serde(default)]
    pub repetitions: Option<i64>,
    /// Options of every run.
    #[serde(default)]
    pub fixed: toml::Table,
    /// Parameters to vary independently (Cartesian product), in order: the first varies slowest.
    #[serde(default)]
    pub vary: toml::Table,
    /// Groups of parameters that vary together, each an axis after the `[vary]` ones.
    #[serde(default)]
    pub zip: Vec<toml::Table>,
    /// Plots to draw.
    #[serde(default)]
    pub plot: Vec<RawPlot>,
    /// The summary table.
    #[serde(default)]
    pub summary: Option<RawSummary>,
}

/// A `[[plot]]` entry as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPlot {
    /// Column on the x axis (a parameter or a statistic).
    pub x: String,
    /// Columns on the y axis.
    pub y: OneOrMany,
    /// Parameters whose values make separate series (default: every varied parameter other than x).
    #[serde(default)]
    pub series: Option<OneOrMany>,
    /// PNG file name in the results folder (default `Y-vs-X.png`).
    #[serde(default)]
    pub file: Option<String>,
    /// `line` (median over repetitions, joined in x order) or `scatter` (every run a dot).
    #[serde(default)]
    pub kind: Option<String>,
    /// Logarithmic x axis.
    #[serde(default)]
    pub log_x: bool,
    /// Logarithmic y axis.
    #[serde(default)]
    pub log_y: bool,
    /// Title (default: the sweep name).
    #[serde(default)]
    pub title: Option<String>,
    /// Keep only runs whose parameters have these values (e.g. one view of a zip).
    #[serde(default, rename = "where")]
    pub filter: toml::Table,
    /// Legend corner: `upper-right` (default), `upper-left`, `lower-left`,
    /// `lower-right`, `upper-middle`, `lower-middle`, `middle-left`, `middle-right`.
    #[serde(default)]
    pub legend: Option<String>,
}

/// A string or a list of strings.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum OneOrMany {
    /// One name.
    One(String),
    /// Several names.
    Many(Vec<String>),
}

impl OneOrMany {
    pub(super) fn into_vec(self) -> Vec<String> {
        match self {
            Self::One(s) => vec![s],
            Self::Many(v) => v,
        }
    }
}

/// The `[summary]` table as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawSummary {
    /// Columns whose median over repetitions is shown per point.
    pub columns: Vec<String>,
}

/// A `[[make]]` entry as written: the files one pvrsim command makes.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawMake {
    /// The files it writes (relative to the config file).
    pub files: Vec<String>,
    /// The pvrsim command line without `pvrsim` (e.g. `generate paper-engine
    /// --input ... -o ...`), paths relative to the config file; split at
    /// white space.
    pub run: String,
}
