//! Running the points of a sweep: each point's parameters become a job
//! (options by flag name, [`crate::job::args::by_name`]), parsed by the job's own
//! clap definition, so the sweep never needs to know the options: whatever
//! `render` accepts, a sweep can vary, under the same name.

use std::path::Path;
use std::time::Instant;

use super::grid::{ParamValue, Point};
use crate::job::args::by_name::{self as options, clap_message, flag};
use crate::job::{sweep, ClusterJob, JobError, RenderJob};

/// A subcommand that sweeps can run.
pub struct Executor {
    /// Subcommand name (the config's `command`).
    pub command: &'static str,
    /// Parameters passed as positional arguments, in this order (e.g. `scene`).
    pub positional: &'static [&'static str],
    /// Parameters holding paths, resolved against the config file's folder.
    pub path_keys: &'static [&'static str],
    /// Parses a command line (without the program name) and reports clap's error.
    pub check: fn(&[String]) -> Result<(), clap::Error>,
    /// Parses and executes a command line, returning the run's statistics.
    pub run: fn(&[String]) -> anyhow::Result<serde_json::Value>,
}

impl std::fmt::Debug for Executor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Executor")
            .field("command", &self.command)
            .finish_non_exhaustive()
    }
}

/// The validation layer's verdict on a point, as a clap error (so a sweep
/// reports it like any other refused command line).
fn validated(checked: Result<Vec<String>, JobError>) -> Result<(), clap::Error> {
    checked.map(|_| ()).map_err(|e| match e {
        JobError::Options(c) => *c,
        e => clap::Error::raw(clap::error::ErrorKind::ValueValidation, format!("{e}\n")),
    })
}

/// A point's options by flag name from its command line (`scene`, then
/// `--name=value` / `--flag`), through the job's own clap definition.
fn render_check(argv: &[String]) -> Result<(), clap::Error> {
    let job: RenderJob = options::parse("pvrsim render", argv)?;
    validated(job.check())
}

fn render_run(argv: &[String]) -> anyhow::Result<serde_json::Value> {
    let job: RenderJob = options::parse("pvrsim render", argv)?;
    Ok(job.run()?.stats)
}

fn cluster_check(argv: &[String]) -> Result<(), clap::Error> {
    let job: ClusterJob = options::parse("pvrsim cluster", argv)?;
    validated(job.check())
}

/// Runs a cluster point; the row's statistics are the flat report of
/// [`crate::job::sweep::flat_report`].
fn cluster_run(argv: &[String]) -> anyhow::Result<serde_json::Value> {
    let job: ClusterJob = options::parse("pvrsim cluster", argv)?;
    Ok(sweep::flat_report(&job.run()?))
}

/// The sweepable subcommands. A new one is one more entry.
static EXECUTORS: [Executor; 2] = [
    Executor {
        command: "render",
        positional: &["scene"],
        path_keys: &["scene"],
        check: render_check,
        run: render_run,
    },
    Executor {
        command: "cluster",
        positional: &["scene"],
        path_keys: &["scene"],
        check: cluster_check,
        run: cluster_run,
    },
];

/// All sweepable subcommands.
pub fn executors() -> &'static [Executor] {
    &EXECUTORS
}

/// The executor of a subcommand, if it is sweepable.
pub fn executor(command: &str) -> Option<&'static Executor> {
    EXECUTORS.iter().find(|e| e.command == command)
}

/// The command line (without the program and subcommand names) of one
/// point: positional parameters first, then `--name=value` per parameter,
/// a bare `--name` for `true`, nothing for `false`. Path parameters are
/// resolved against `base_dir`.
pub fn command_line(exec: &Executor, base_dir: &Path, point: &Point) -> Vec<String> {
    options::argv(exec.positional, point, |k, v| match v {
        ParamValue::Str(s) if exec.path_keys.contains(&k) => base_dir.join(s).display().to_string(),
        other => other.to_string(),
    })
}

/// Checks a point's command line with clap; the error names the parameter
/// clap complained about (and where the config sets it), or the whole point.
pub fn check_point(
    exec: &Executor,
    base_dir: &Path,
    point: &Point,
    origin: impl Fn(&str) -> String,
) -> Result<(), String> {
    let argv = command_line(exec, base_dir, point);
    let Err(e) = (exec.check)(&argv) else {
        return Ok(());
    };
    let msg = clap_message(&e);
    let arg = e
        .get(clap::error::ContextKind::InvalidArg)
        .map(|v| v.to_string())
        .unwrap_or_default();
    let culprit = point.iter().find(|(k, _)| {
        let f = flag(k);
        arg == f || arg.starts_with(&format!("{f} ")) || arg.starts_with(&format!("{f}="))
    });
    Err(match culprit {
        Some((k, v)) => format!(
            "parameter `{k}` (set by {}, `{k} = {v}`) is not accepted by `pvrsim {}`: {msg}",
            origin(k),
            exec.command
        ),
        None => {
            let params: Vec<String> = point.iter().map(|(k, v)| format!("{k}={v}")).collect();
            format!(
                "the run with {} is not accepted by `pvrsim {}`: {msg}",
                params.join(", "),
                exec.command
            )
        }
    })
}

/// What one run produced.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// Wall time of the whole run (parse, load, render), seconds.
    pub wall_s: f64,
    /// The statistics, or the error message.
    pub outcome: Result<serde_json::Value, String>,
}

/// Executes one run; an error or a panic is recorded, never propagated.
pub fn run_point(exec: &Executor, base_dir: &Path, point: &Point) -> RunResult {
    let argv = command_line(exec, base_dir, point);
    let t = Instant::now();
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| (exec.run)(&argv)));
    let wall_s = t.elapsed().as_secs_f64();
    let outcome = match outcome {
        Ok(Ok(stats)) => Ok(stats),
        Ok(Err(e)) => Err(e
            .chain()
            .map(|c| c.to_string())
            .collect::<Vec<_>>()
            .join(": ")),
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(format!("panicked: {what}"))
        }
    };
    RunResult { wall_s, outcome }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(items: &[(&str, ParamValue)]) -> Point {
        items
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect()
    }

    #[test]
    fn command_lines() {
        let exec = executor("render").unwrap();
        let p = point(&[
            ("threads", ParamValue::Int(1)),
            ("scene", ParamValue::Str("s.toml".into())),
            ("compare", ParamValue::Bool(true)),
            ("no_partial_composition", ParamValue::Bool(false)),
            ("cell_order", ParamValue::Str("input".into())),
        ]);
        let argv = command_line(exec, Path::new("cfg"), &p);
        assert_eq!(
            argv,
            [
                "cfg/s.toml",
                "--threads=1",
                "--compare",
                "--cell-order=input"
            ]
        );
    }

    #[test]
    fn clap_errors_name_the_parameter() {
        let exec = executor("render").unwrap();
        let origin = |k: &str| format!("vary.{k}");
        let bad = point(&[
            ("scene", ParamValue::Str("s.toml".into())),
            ("ert_tabel", ParamValue::Int(3)),
        ]);
        let e = check_point(exec, Path::new("."), &bad, origin).unwrap_err();
        assert!(
            e.contains("`ert_tabel`") && e.contains("vary.ert_tabel") && e.contains("--ert-tabel"),
            "{e}"
        );
        let bad = point(&[
            ("scene", ParamValue::Str("s.toml".into())),
            ("integrator", ParamValue::Str("simpson".into())),
        ]);
        let e = check_point(exec, Path::new("."), &bad, origin).unwrap_err();
        assert!(e.contains("`integrator`") && e.contains("simpson"), "{e}");
        let ok = point(&[
            ("scene", ParamValue::Str("s.toml".into())),
            ("width", ParamValue::Int(3)),
            ("height", ParamValue::Int(3)),
        ]);
        check_point(exec, Path::new("."), &ok, origin).unwrap();
    }
}
