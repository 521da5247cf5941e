//! `pvrsim sweep CONFIG`: runs a config-driven parameter sweep (see
//! docs/sweeps.md) and writes results.csv, summary.md and plots.

use std::io::IsTerminal;
use std::path::PathBuf;

use clap::Args;

use crate::experiment::{parse_only, run_sweep, SweepOptions};

/// Options of `pvrsim sweep`.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Sweep config (TOML; see docs/sweeps.md).
    pub config: PathBuf,
    /// Results root: the sweep writes OUT/NAME/ (results.csv, summary.md, plots).
    #[arg(long, default_value = "results")]
    pub out: PathBuf,
    /// Redo runs that results.csv already has (by default they are skipped).
    #[arg(long)]
    pub force: bool,
    /// List the runs (and which are already done) and estimate how long the
    /// rest would take, without running anything.
    #[arg(long)]
    pub dry_run: bool,
    /// Run only points whose parameter KEY equals VALUE (repeatable: the same
    /// key matches any of its values, different keys must all match).
    #[arg(long, value_name = "KEY=VALUE", value_parser = parse_only)]
    pub only: Vec<(String, String)>,
    /// When a file in `requires` (or the scene) is missing, say so and exit 0
    /// instead of failing.
    #[arg(long)]
    pub allow_missing: bool,
}

/// Runs `pvrsim sweep`.
pub fn run(a: SweepArgs) -> anyhow::Result<()> {
    let opts = SweepOptions {
        config: a.config.clone(),
        out: a.out,
        force: a.force,
        dry_run: a.dry_run,
        only: a.only,
        allow_missing: a.allow_missing,
        progress: std::io::stderr().is_terminal(),
        lines: !std::io::stdout().is_terminal(),
    };
    let r = run_sweep(&opts)?;
    if !r.missing.is_empty() {
        let list: Vec<String> = r.missing.iter().map(|p| p.display().to_string()).collect();
        println!(
            "skipped sweep {}: required file(s) not found: {}",
            a.config.display(),
            list.join(", ")
        );
        return Ok(());
    }
    if opts.dry_run {
        for line in &r.listing {
            println!("{line}");
        }
        println!(
            "{} runs: {} to run, {} already in {}",
            r.runs_selected,
            r.runs_selected - r.runs_skipped,
            r.runs_skipped,
            r.csv.display()
        );
        if let Some(e) = &r.estimate {
            if r.runs_selected > r.runs_skipped {
                println!("{e}");
            }
        }
        return Ok(());
    }
    print!(
        "{}",
        r.summary_text
            .lines()
            .skip_while(|l| !l.starts_with('|'))
            .map(|l| format!("{l}\n"))
            .collect::<String>()
    );
    println!(
        "\n{} runs: {} run now ({} failed), {} already done",
        r.runs_selected, r.runs_executed, r.runs_failed, r.runs_skipped
    );
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    println!("results: {}", r.csv.display());
    if let Some(s) = &r.summary {
        println!("summary: {}", s.display());
    }
    for p in &r.plots {
        println!("plot:    {}", p.display());
    }
    if r.runs_failed > 0 {
        println!("{} run(s) failed; their errors are in the `error` column and at the end of the summary", r.runs_failed);
    }
    Ok(())
}
