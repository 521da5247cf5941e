//! Config-driven experiment sweeps (`pvrsim sweep CONFIG`): a TOML file names
//! a subcommand, fixed options and the options to vary; every point of the
//! grid runs (sequentially, `repetitions` times) through the subcommand's own
//! command-line parser, and the runs land in `OUT/NAME/results.csv`, with a
//! `summary.md` table and PNG plots. See docs/sweeps.md.
//!
//! - [`config`]: the file format, validated into a [`config::Plan`];
//! - [`grid`]: values, ranges, zip groups and their Cartesian product;
//! - [`run`]: parameters to a command line, and the sweepable subcommands;
//! - [`estimate`]: the duration `--dry-run` announces;
//! - [`results`]: the CSV and the summary;
//! - [`plot`]: the PNG plots.

pub mod config;
pub mod estimate;
pub mod fidelity;
pub mod fidelity_plot;
pub mod fidelity_rows;
pub mod grid;
pub mod plot;
pub mod results;
pub mod run;

use std::path::PathBuf;

use anyhow::Context;

use config::{canonical, Plan};
use grid::Point;
use results::Results;

/// What `pvrsim sweep` was asked to do.
#[derive(Debug, Clone, Default)]
pub struct SweepOptions {
    /// The config file.
    pub config: PathBuf,
    /// Results root; the sweep writes to `out/NAME/`.
    pub out: PathBuf,
    /// Redo runs already in the CSV.
    pub force: bool,
    /// List the runs, run nothing, write nothing.
    pub dry_run: bool,
    /// Keep only points where parameter KEY has text VALUE (same key: any of the values; different keys: all).
    pub only: Vec<(String, String)>,
    /// Skip the sweep (successfully) when a required file is missing.
    pub allow_missing: bool,
    /// Show a progress bar on stderr (when it is a terminal).
    pub progress: bool,
    /// Print one line per finished run on stdout (when stdout is not a
    /// terminal: piped, logged, CI), with the count, the run's time and the
    /// time elapsed.
    pub lines: bool,
}

/// What a sweep did.
#[derive(Debug, Clone, Default)]
pub struct SweepReport {
    /// `out/NAME/`.
    pub out_dir: PathBuf,
    /// The results CSV.
    pub csv: PathBuf,
    /// summary.md, when written.
    pub summary: Option<PathBuf>,
    /// The summary's text.
    pub summary_text: String,
    /// Plots written.
    pub plots: Vec<PathBuf>,
    /// Runs selected (points after `--only`, times repetitions).
    pub runs_selected: usize,
    /// Runs executed now.
    pub runs_executed: usize,
    /// Runs skipped because the CSV already had them.
    pub runs_skipped: usize,
    /// Runs executed now that failed.
    pub runs_failed: usize,
    /// Things the user should know (unknown summary or plot columns, points left out of plots).
    pub warnings: Vec<String>,
    /// Required files that were missing (the sweep was skipped under `allow_missing`).
    pub missing: Vec<PathBuf>,
    /// For a dry run: one line per run.
    pub listing: Vec<String>,
    /// For a dry run: how long the runs to do would take.
    pub estimate: Option<estimate::Estimate>,
}

/// Parses `KEY=VALUE` of `--only`.
pub fn parse_only(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.trim().to_string())),
        _ => Err(format!("expected KEY=VALUE, found `{s}`")),
    }
}

fn describe(point: &Point, n: usize) -> String {
    let v: Vec<String> = point
        .iter()
        .take(n)
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    if v.is_empty() {
        "(single point)".into()
    } else {
        v.join(" ")
    }
}

/// Selects the points matching `--only`; errors name unknown keys and list the values.
fn select(
    plan: &Plan,
    points: Vec<Point>,
    only: &[(String, String)],
) -> anyhow::Result<Vec<Point>> {
    let names = plan.param_names();
    for (k, v) in only {
        let Some(name) = names.iter().find(|n| canonical(n) == canonical(k)) else {
            anyhow::bail!(
                "--only {k}={v}: `{k}` is not a parameter of {} (parameters: {})",
                plan.path.display(),
                names.join(", ")
            );
        };
        if !points
            .iter()
            .any(|p| p.iter().any(|(n, x)| n == name && x.to_string() == *v))
        {
            let mut values: Vec<String> = points
                .iter()
                .filter_map(|p| {
                    p.iter()
                        .find(|(n, _)| n == name)
                        .map(|(_, x)| x.to_string())
                })
                .collect();
            let mut seen = Vec::new();
            values.retain(|v| {
                let new = !seen.contains(v);
                seen.push(v.clone());
                new
            });
            anyhow::bail!(
                "--only {k}={v}: no point has {name}={v} (values: {})",
                values.join(", ")
            );
        }
    }
    Ok(points
        .into_iter()
        .filter(|p| {
            let mut keys: Vec<String> = only.iter().map(|(k, _)| canonical(k)).collect();
            keys.dedup();
            keys.iter().all(|key| {
                let value = p
                    .iter()
                    .find(|(n, _)| canonical(n) == *key)
                    .map(|(_, x)| x.to_string());
                only.iter()
                    .filter(|(k, _)| canonical(k) == *key)
                    .any(|(_, v)| value.as_deref() == Some(v.as_str()))
            })
        })
        .collect())
}

/// Missing files of a sweep: made by the config's `[[make]]` commands
/// (generated data: deterministic, so made once and then found), each
/// announced on stderr before it runs; a dry run lists them instead. Files
/// no command makes are an error that says which (and how to make the
/// others).
fn make_missing(
    plan: &Plan,
    missing: &[PathBuf],
    dry_run: bool,
    report: &mut SweepReport,
) -> anyhow::Result<()> {
    let file = plan.path.display();
    let makers = plan.makers_of(missing);
    let unmade: Vec<String> = missing
        .iter()
        .filter(|p| !makers.iter().any(|m| m.files.contains(*p)))
        .map(|p| p.display().to_string())
        .collect();
    let how = || {
        let cmds: Vec<String> = makers.iter().map(|m| m.shown()).collect();
        if cmds.is_empty() {
            String::new()
        } else {
            format!(
                "; the sweep makes the generated ones itself (in {}): {}",
                plan.base_dir.display(),
                cmds.join("; ")
            )
        }
    };
    if !unmade.is_empty() {
        anyhow::bail!(
            "{file}: required file(s) not found: {} (paths are relative to the config file; \
             --allow-missing skips this sweep){}",
            unmade.join(", "),
            how()
        );
    }
    if dry_run {
        for m in &makers {
            report.listing.push(format!(
                "make  {} (in {})",
                m.shown(),
                plan.base_dir.display()
            ));
        }
        return Ok(());
    }
    let exe = std::env::current_exe().context("cannot find this program's path")?;
    anyhow::ensure!(
        exe.file_stem().is_some_and(|s| s == "pvrsim"),
        "{file}: required file(s) not found: {} (generated data: make them with the \
         pvrsim command line, in {}: {})",
        missing
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", "),
        plan.base_dir.display(),
        makers
            .iter()
            .map(|m| m.shown())
            .collect::<Vec<_>>()
            .join("; ")
    );
    for (k, m) in makers.iter().enumerate() {
        for f in &m.files {
            if let Some(d) = f.parent() {
                std::fs::create_dir_all(d)
                    .with_context(|| format!("{file}: cannot create {}", d.display()))?;
            }
        }
        eprintln!(
            "making generated data ({} of {}, once; later sweeps find it): {} (in {})",
            k + 1,
            makers.len(),
            m.shown(),
            plan.base_dir.display()
        );
        let status = std::process::Command::new(&exe)
            .args(&m.args)
            .current_dir(&plan.base_dir)
            .stdout(std::process::Stdio::inherit())
            .stderr(std::process::Stdio::inherit())
            .status()
            .with_context(|| format!("{file}: cannot run {}", m.shown()))?;
        anyhow::ensure!(
            status.success(),
            "{file}: making {} failed ({status}; its message is above): {}",
            m.files
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
            m.shown()
        );
        if let Some(f) = m.files.iter().find(|f| !f.exists()) {
            anyhow::bail!("{file}: {} did not write {}", m.shown(), f.display());
        }
    }
    Ok(())
}

/// Runs a sweep: validates the config and every run's command line before
/// running anything, then runs what the CSV lacks (everything with
/// `force`), one run at a time, saving the CSV after each run; then writes
/// summary.md and the plots.
pub fn run_sweep(opts: &SweepOptions) -> anyhow::Result<SweepReport> {
    let plan = Plan::load(&opts.config)?;
    let file = plan.path.display().to_string();
    let mut report = SweepReport {
        out_dir: opts.out.join(&plan.name),
        ..Default::default()
    };
    report.csv = report.out_dir.join("results.csv");

    let missing = plan.missing_files();
    if !missing.is_empty() {
        if opts.allow_missing {
            report.missing = missing;
            return Ok(report);
        }
        make_missing(&plan, &missing, opts.dry_run, &mut report)?;
    }

    let points = select(&plan, plan.points(), &opts.only)?;
    for p in &points {
        run::check_point(plan.executor, &plan.base_dir, p, |k| {
            plan.origin(k).to_string()
        })
        .map_err(|e| anyhow::anyhow!("{file}: {e}"))?;
    }
    let mut results = Results::load(&report.csv)?;
    let n_varied = plan.grid.names().len();
    let mut todo: Vec<(&Point, usize)> = Vec::new();
    for p in &points {
        for rep in 0..plan.repetitions {
            report.runs_selected += 1;
            let done = results.find(p, rep).is_some_and(|i| {
                results.rows[i].get("status").map(String::as_str) == Some(results::OK)
            });
            if done && !opts.force {
                report.runs_skipped += 1;
                if opts.dry_run {
                    report
                        .listing
                        .push(format!("done  {} rep {rep}", describe(p, n_varied)));
                }
            } else {
                if opts.dry_run {
                    let argv = run::command_line(plan.executor, &plan.base_dir, p);
                    report.listing.push(format!(
                        "run   {} rep {rep}: pvrsim {} {}",
                        describe(p, n_varied),
                        plan.executor.command,
                        argv.join(" ")
                    ));
                }
                todo.push((p, rep));
            }
        }
    }
    if opts.dry_run {
        report.estimate = Some(estimate::estimate(
            plan.executor.command,
            &plan.base_dir,
            &todo,
            &results,
        ));
        return Ok(report);
    }

    std::fs::create_dir_all(&report.out_dir)
        .with_context(|| format!("cannot create {}", report.out_dir.display()))?;
    let _ = std::fs::copy(&plan.path, report.out_dir.join("config.toml"));
    let pb = if opts.progress {
        let pb = indicatif::ProgressBar::new(todo.len() as u64);
        pb.enable_steady_tick(std::time::Duration::from_millis(250));
        pb
    } else {
        indicatif::ProgressBar::hidden()
    };
    pb.set_style(
        indicatif::ProgressStyle::with_template("{spinner} [{bar:30}] {pos}/{len} runs, {elapsed_precise} elapsed, ETA {eta_precise}  {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let t0 = std::time::Instant::now();
    for (k, (p, rep)) in todo.iter().enumerate() {
        pb.set_message(format!("{} rep {rep}", describe(p, n_varied)));
        crate::base::cancel::checkpoint();
        let r = run::run_point(plan.executor, &plan.base_dir, p);
        // A run cut short by cancellation is not a failed run: stop here.
        crate::base::cancel::checkpoint();
        if let Err(e) = &r.outcome {
            report.runs_failed += 1;
            pb.suspend(|| eprintln!("run failed ({} rep {rep}): {e}", describe(p, n_varied)));
        }
        if opts.lines {
            pb.suspend(|| {
                println!(
                    "[{}/{}] {} rep {rep}: {} in {:.2} s ({:.1} s elapsed)",
                    k + 1,
                    todo.len(),
                    describe(p, n_varied),
                    if r.outcome.is_ok() { "ok" } else { "FAILED" },
                    r.wall_s,
                    t0.elapsed().as_secs_f64()
                )
            });
        }
        results.record(p, *rep, r.wall_s, &r.outcome);
        results.save(&plan)?;
        report.runs_executed += 1;
        pb.inc(1);
    }
    pb.finish_and_clear();
    if todo.is_empty() && !report.csv.exists() {
        results.save(&plan)?;
    }

    let (text, warnings) = results::summary(&plan, &results);
    report.warnings.extend(warnings);
    let summary = report.out_dir.join("summary.md");
    std::fs::write(&summary, &text)
        .with_context(|| format!("cannot write {}", summary.display()))?;
    report.summary = Some(summary);
    report.summary_text = text;
    for spec in &plan.plots {
        if let Some(e) = plot::unknown_column(&plan, spec, &results) {
            anyhow::bail!("{e} (results.csv and summary.md are written)");
        }
    }
    for spec in &plan.plots {
        match plot::draw(&plan, spec, &results, &report.out_dir) {
            Ok(w) => {
                report.warnings.extend(w);
                report.plots.push(report.out_dir.join(&spec.file));
            }
            Err(e) => report.warnings.push(e),
        }
    }
    Ok(report)
}
