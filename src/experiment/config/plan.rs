//! A validated sweep ([`Plan`]): [`Plan::parse`] checks a [`RawConfig`]
//! key by key (every error names the file and the key) and expands the
//! parameter grid; the plan answers which points to run and which files
//! must exist.

use std::path::{Path, PathBuf};

use super::raw::RawConfig;
use crate::experiment::grid::{values_of, Dimension, Grid, ParamValue, Point};
use crate::experiment::run::{executor, executors, Executor};

/// Kind of plot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlotKind {
    /// y (median over repetitions) against x, one line per series.
    Line,
    /// Every successful run as a dot, one colour per series.
    Scatter,
}

/// Accepted values of a plot's `legend`.
pub const LEGEND_POSITIONS: [&str; 8] = [
    "upper-right",
    "upper-left",
    "lower-left",
    "lower-right",
    "upper-middle",
    "lower-middle",
    "middle-left",
    "middle-right",
];

/// A validated plot.
#[derive(Debug, Clone)]
pub struct PlotSpec {
    /// Column on the x axis.
    pub x: String,
    /// Columns on the y axis.
    pub y: Vec<String>,
    /// Parameters that separate series.
    pub series: Vec<String>,
    /// File name in the results folder.
    pub file: String,
    /// Line or scatter.
    pub kind: PlotKind,
    /// Log x axis.
    pub log_x: bool,
    /// Log y axis.
    pub log_y: bool,
    /// Title.
    pub title: String,
    /// Only runs whose parameter (first) has the value (second, as in the CSV).
    pub filter: Vec<(String, String)>,
    /// Legend corner (one of [`LEGEND_POSITIONS`]).
    pub legend: String,
    /// `plot[i]`, for messages.
    pub key: String,
}

/// Generated data of a sweep: the files one pvrsim command makes.
#[derive(Debug, Clone, PartialEq)]
pub struct Make {
    /// The files it writes, resolved against the config's folder.
    pub files: Vec<PathBuf>,
    /// The command line without `pvrsim`, run in the config's folder.
    pub args: Vec<String>,
}

impl Make {
    /// The command as a user types it from the config's folder.
    pub fn shown(&self) -> String {
        format!("pvrsim {}", self.args.join(" "))
    }
}

/// A validated sweep: what to run and what to report.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The config file.
    pub path: PathBuf,
    /// Folder of the config file; relative paths are resolved against it.
    pub base_dir: PathBuf,
    /// Sweep name.
    pub name: String,
    /// Free text.
    pub description: Option<String>,
    /// The executor of each run.
    pub executor: &'static Executor,
    /// Required files, resolved.
    pub requires: Vec<PathBuf>,
    /// Commands that make generated data, with the files each writes.
    pub make: Vec<Make>,
    /// Runs per point.
    pub repetitions: usize,
    /// Parameters of every run, in config order.
    pub fixed: Point,
    /// Parameters that vary.
    pub grid: Grid,
    /// Where each parameter was set (`fixed.threads`, `vary.ert_table`, `zip[0].width`, `scene`).
    pub origins: Vec<(String, String)>,
    /// Plots.
    pub plots: Vec<PlotSpec>,
    /// Summary columns.
    pub summary_columns: Vec<String>,
}

/// Column names the sweep itself writes; no parameter may take them.
pub const RESERVED: [&str; 4] = ["repetition", "status", "wall_s", "error"];

impl Plan {
    /// Reads and validates a config file.
    pub fn load(path: &Path) -> anyhow::Result<Plan> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("cannot read sweep config {}: {e}", path.display()))?;
        Self::parse(&text, path)
    }

    /// Validates config text; `path` names the file in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> anyhow::Result<Plan> {
        let file = path.display().to_string();
        let err = |msg: String| anyhow::anyhow!("{file}: {msg}");
        let raw: RawConfig = toml::from_str(text).map_err(|e| {
            let at = e
                .span()
                .map(|s| {
                    let line = text[..s.start.min(text.len())].matches('\n').count() + 1;
                    format!(" (line {line})")
                })
                .unwrap_or_default();
            err(format!("{}{at}", e.message().trim()))
        })?;
        let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let base_dir = if base_dir.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            base_dir
        };

        let name = raw.name.trim().to_string();
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
            || name.starts_with('.')
        {
            return Err(err(format!("name: `{}` must be non-empty letters, digits, `-`, `_`, `.` (it names the results folder)", raw.name)));
        }
        let command = raw.command.unwrap_or_else(|| "render".into());
        let executor = executor(&command).ok_or_else(|| {
            let known: Vec<&str> = executors().iter().map(|e| e.command).collect();
            err(format!(
                "command: unknown command `{command}`; sweepable commands: {}",
                known.join(", ")
            ))
        })?;
        let repetitions = match raw.repetitions {
            None => 1,
            Some(r) if (1..=10_000).contains(&r) => r as usize,
            Some(r) => return Err(err(format!("repetitions: must be 1..=10000, found {r}"))),
        };

        let mut origins: Vec<(String, String)> = Vec::new();
        let mut claim = |name: &str, origin: String| -> anyhow::Result<()> {
            if !valid_param(name) {
                return Err(err(format!(
                    "{origin}: `{name}` is not a parameter name (letters, digits, `_`, `-`)"
                )));
            }
            if RESERVED.contains(&name) {
                return Err(err(format!("{origin}: `{name}` is a column the sweep writes itself; it cannot be a parameter")));
            }
            let canon = canonical(name);
            if let Some((_, first)) = origins.iter().find(|(n, _)| canonical(n) == canon) {
                return Err(err(format!(
                    "{origin}: parameter `{name}` is already set by {first}"
                )));
            }
            origins.push((name.to_string(), origin));
            Ok(())
        };

        let mut fixed: Point = Vec::new();
        if let Some(scene) = raw.scene {
            claim("scene", "scene".into())?;
            fixed.push(("scene".into(), ParamValue::Str(scene)));
        }
        for (k, v) in &raw.fixed {
            let origin = format!("fixed.{k}");
            claim(k, origin.clone())?;
            let value = ParamValue::from_toml(v, &origin).map_err(|m| {
                if matches!(v, toml::Value::Array(_)) {
                    err(format!("{m}; a list of values to sweep goes in [vary]"))
                } else {
                    err(m)
                }
            })?;
            fixed.push((k.clone(), value));
        }
        let mut grid = Grid::default();
        for (k, v) in &raw.vary {
            let origin = format!("vary.{k}");
            claim(k, origin.clone())?;
            let values = values_of(v, &origin).map_err(err)?;
            grid.dims.push(Dimension {
                names: vec![k.clone()],
                tuples: values.into_iter().map(|v| vec![v]).collect(),
            });
        }
        for (i, group) in raw.zip.iter().enumerate() {
            if group.is_empty() {
                return Err(err(format!("zip[{i}]: empty group")));
            }
            let mut names = Vec::new();
            let mut columns: Vec<Vec<ParamValue>> = Vec::new();
            for (k, v) in group {
                let origin = format!("zip[{i}].{k}");
                claim(k, origin.clone())?;
                let values = values_of(v, &origin).map_err(err)?;
                if let Some(first) = columns.first() {
                    if first.len() != values.len() {
                        return Err(err(format!(
                            "{origin}: {} values, but zip[{i}].{} has {}; parameters in a zip group vary together and need as many values",
                            values.len(),
                            names[0],
                            first.len()
                        )));
                    }
                }
                names.push(k.clone());
                columns.push(values);
            }
            let n = columns[0].len();
            let tuples = (0..n)
                .map(|j| columns.iter().map(|c| c[j].clone()).collect())
                .collect();
            grid.dims.push(Dimension { names, tuples });
        }
        if grid.len() > 1_000_000 {
            return Err(err(format!(
                "vary: {} points; that is more than a sweep should have",
                grid.len()
            )));
        }
        for p in executor.positional {
            if !origins.iter().any(|(n, _)| n == p) {
                return Err(err(format!("`{command}` needs `{p}` (set `{p} = \"...\"` at the top, or in [fixed] or [vary])")));
            }
        }
        let requires = raw.requires.iter().map(|r| base_dir.join(r)).collect();
        let mut make = Vec::new();
        for (i, m) in raw.make.iter().enumerate() {
            let args: Vec<String> = m.run.split_whitespace().map(str::to_string).collect();
            if args.is_empty() || m.files.is_empty() {
                return Err(err(format!(
                    "make[{i}]: needs `files = [...]` and `run = \"COMMAND ...\"` (a pvrsim command line)"
                )));
            }
            if args[0] != "generate" {
                return Err(err(format!(
                    "make[{i}].run: `{}`: data is made by `generate` (e.g. `generate paper-engine --input GRID -o OUT.nrrd`)",
                    args[0]
                )));
            }
            make.push(Make {
                files: m.files.iter().map(|f| base_dir.join(f)).collect(),
                args,
            });
        }

        let params: Vec<String> = origins.iter().map(|(n, _)| n.clone()).collect();
        let varied = grid.names();
        let mut plots = Vec::new();
        let mut files: Vec<String> = Vec::new();
        for (i, p) in raw.plot.into_iter().enumerate() {
            let key = format!("plot[{i}]");
            let y = p.y.into_vec();
            if y.is_empty() {
                return Err(err(format!("{key}.y: no column to plot")));
            }
            let kind = match p.kind.as_deref() {
                None | Some("line") => PlotKind::Line,
                Some("scatter") => PlotKind::Scatter,
                Some(other) => {
                    return Err(err(format!(
                        "{key}.kind: `{other}`; expected `line` or `scatter`"
                    )))
                }
            };
            let series = match p.series {
                Some(s) => {
                    let s = s.into_vec();
                    for name in &s {
                        if !params.contains(name) {
                            return Err(err(format!("{key}.series: `{name}` is not a parameter of this sweep (parameters: {})", params.join(", "))));
                        }
                    }
                    s
                }
                None => {
                    // Every varied parameter except x, its zip partners (they move with x) and y.
                    let with_x: Vec<&String> = grid
                        .dims
                        .iter()
                        .filter(|d| d.names.contains(&p.x))
                        .flat_map(|d| d.names.iter())
                        .collect();
                    varied
                        .iter()
                        .filter(|n| **n != p.x && !with_x.contains(n) && !y.contains(n))
                        .cloned()
                        .collect()
                }
            };
            let file = p.file.unwrap_or_else(|| {
                format!("{}-vs-{}.png", y[0], p.x).replace(
                    |c: char| !(c.is_ascii_alphanumeric() || "-_.".contains(c)),
                    "_",
                )
            });
            if !file.ends_with(".png") || file.contains(['/', '\\']) || file.starts_with('.') {
                return Err(err(format!(
                    "{key}.file: `{file}` must be a file name ending in .png (no folders)"
                )));
            }
            if files.contains(&file) {
                return Err(err(format!(
                    "{key}.file: `{file}` is already written by another plot"
                )));
            }
            files.push(file.clone());
            let title = p.title.unwrap_or_else(|| name.clone());
            let mut filter = Vec::new();
            for (k, v) in &p.filter {
                if !params.contains(k) {
                    return Err(err(format!(
                        "{key}.where: `{k}` is not a parameter of this sweep (parameters: {})",
                        params.join(", ")
                    )));
                }
                let v = match v {
                    toml::Value::String(s) => s.clone(),
                    other => other.to_string(),
                };
                filter.push((k.clone(), v));
            }
            let legend = p.legend.unwrap_or_else(|| "upper-right".into());
            if !LEGEND_POSITIONS.contains(&legend.as_str()) {
                return Err(err(format!(
                    "{key}.legend: `{legend}` is not one of {}",
                    LEGEND_POSITIONS.join(", ")
                )));
            }
            plots.push(PlotSpec {
                x: p.x,
                y,
                series,
                file,
                kind,
                log_x: p.log_x,
                log_y: p.log_y,
                title,
                filter,
                legend,
                key,
            });
        }
        let summary_columns = match raw.summary {
            Some(s) if !s.columns.is_empty() => s.columns,
            Some(_) => return Err(err("summary.columns: empty list".into())),
            None => vec!["wall_s".into()],
        };
        Ok(Plan {
            path: path.to_path_buf(),
            base_dir,
            name,
            description: raw.description,
            executor,
            requires,
            make,
            repetitions,
            fixed,
            grid,
            origins,
            plots,
            summary_columns,
        })
    }

    /// Where a parameter was set, e.g. `vary.ert_table`.
    pub fn origin<'a>(&'a self, name: &'a str) -> &'a str {
        self.origins
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, o)| o.as_str())
            .unwrap_or(name)
    }

    /// Every point, each with the varied parameters first, then the fixed ones.
    pub fn points(&self) -> Vec<Point> {
        self.grid
            .points()
            .into_iter()
            .map(|mut p| {
                p.extend(self.fixed.iter().cloned());
                p
            })
            .collect()
    }

    /// Names of all parameters: varied first, then fixed.
    pub fn param_names(&self) -> Vec<String> {
        let mut v = self.grid.names();
        v.extend(self.fixed.iter().map(|(n, _)| n.clone()));
        v
    }

    /// Required files (and files named by path parameters such as `scene`) that do not exist.
    pub fn missing_files(&self) -> Vec<PathBuf> {
        let mut missing: Vec<PathBuf> = self
            .requires
            .iter()
            .filter(|p| !p.exists())
            .cloned()
            .collect();
        for point in self.points() {
            for (k, v) in &point {
                if let (true, ParamValue::Str(s)) =
                    (self.executor.path_keys.contains(&k.as_str()), v)
                {
                    let p = self.base_dir.join(s);
                    if !p.exists() && !missing.contains(&p) {
                        missing.push(p);
                    }
                }
            }
        }
        missing
    }

    /// The `[[make]]` entries that write a file of `missing`, in config order.
    pub fn makers_of(&self, missing: &[PathBuf]) -> Vec<&Make> {
        self.make
            .iter()
            .filter(|m| m.files.iter().any(|f| missing.contains(f)))
            .collect()
    }
}

fn valid_param(name: &str) -> bool {
    !name.is_empty()
        && !name.starts_with('-')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// `ert_table` and `ert-table` are the same option.
pub fn canonical(name: &str) -> String {
    name.replace('-', "_")
}
