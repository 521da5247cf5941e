//! `pvrsim cluster`: a scene on a simulated (or real) PC cluster. The options
//! and the work are the job layer's ([`crate::job::cluster`], re-exported
//! here; its one path is [`crate::job::cluster::load`]); this file checks the
//! outputs, runs the job and writes its files.

use anyhow::Context;

use crate::cluster::grid::GridOutcome;
use crate::image::Image;
pub use crate::job::cluster::*;
use crate::job::output::{self, prepare_output, OutputKind};
use crate::job::series::output as series_output;
use crate::job::{ClusterResult, Valid};
use crate::net::SimTrace;

/// Runs `pvrsim cluster`: validates the options and checks every output
/// path first, then loads the scene once and runs it.
pub fn run(a: ClusterArgs) -> anyhow::Result<()> {
    // Under mpirun, ranks other than 0 serve a node and write nothing.
    if crate::job::nodes::serve_mpi_worker(&a.net, a.nodes)? {
        return Ok(());
    }
    // An error on MPI rank 0 ends every rank of the job (MPI_Abort).
    coordinate(&a).map_err(|e| crate::job::nodes::abort_on_error(&a.net, e))
}

/// `pvrsim cluster` on this process (MPI rank 0 under `mpirun`).
fn coordinate(a: &ClusterArgs) -> anyhow::Result<()> {
    let job = Valid::new(a)?;
    job.print_warnings();
    prepare_output("-o", &a.output, OutputKind::Png)?;
    for (flag, path, kind) in [
        ("--report", &a.report, OutputKind::Json),
        ("--trace", &a.trace, OutputKind::Json),
        ("--timeline", &a.timeline, OutputKind::Png),
    ] {
        if let Some(p) = path {
            prepare_output(flag, p, kind)?;
        }
    }
    if let Some(p) = &a.series.series_csv {
        prepare_output("--series-csv", p, OutputKind::Csv)?;
    }
    let started = std::time::Instant::now();
    // Ctrl-C or SIGTERM stop a series between frames: the frames done are
    // on disk (each is written as it completes), the workers end with it.
    crate::base::cancel::on_signals();
    let mut done = 0usize;
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        job.load()?.run_with_progress(|k, n, out| {
            done = k + 1;
            if n > 1 {
                eprintln!(
                    "frame {}/{n} done ({:.1} s)",
                    k + 1,
                    started.elapsed().as_secs_f64()
                );
            }
            match series_output::write_frame(&a.output, k, n, &out.image) {
                Ok(Some(line)) => println!("{line}"),
                Ok(None) => {}
                Err(e) => {
                    eprintln!("error: {e:#}");
                    crate::base::cancel::set(true);
                }
            }
        })
    }));
    let result = match run {
        Ok(r) => r?,
        Err(p) if crate::base::cancel::is_cancelled(p.as_ref()) => {
            let kept = match crate::job::series::args::frame_path(&a.output, 0) {
                Some(_) if done > 0 => format!(
                    "frames 0..{done} are on disk; add --resume to the same command to continue"
                ),
                _ => "nothing was written".to_string(),
            };
            anyhow::bail!("stopped after {done} frame(s): {kept}");
        }
        Err(p) => std::panic::resume_unwind(p),
    };
    match &result {
        ClusterResult::Grid(outs) => write_grid(a, outs)?,
        ClusterResult::Mesh(outs) => {
            let out = outs.last().expect("at least one frame");
            output::warn_if_empty(
                &out.image,
                &format!(
                    "{} of {} cells culled on arrival",
                    out.report.nodes.iter().map(|x| x.cells_culled).sum::<u64>(),
                    out.report.cells_total
                ),
            );
            let images: Vec<&Image> = outs.iter().map(|o| &o.image).collect();
            let lines =
                series_output::write_series_images(Some(&a.output), &a.series, &images, true)?;
            for line in lines {
                println!("{line}");
            }
            let (trace, ranks) = result.trace();
            write_outputs(a, &out.report, &trace, ranks)?;
            if let Some(line) = series_output::write_series_csv(&a.series, &out.report)? {
                println!("{line}");
            }
        }
    }
    print!("{}", result.summary());
    Ok(())
}

/// Writes the outputs `pvrsim cluster` names for the frames of a grid scene.
fn write_grid(a: &ClusterArgs, outs: &[GridOutcome]) -> anyhow::Result<()> {
    if outs.len() > 1 {
        let walls: Vec<f64> = outs.iter().map(|o| o.report.wall_s).collect();
        let cached: Vec<u64> = outs.iter().map(|o| o.report.textures_cached).collect();
        println!(
            "{} frames, wall seconds each: {}; total {:.4} s; bricks from kept textures each: {:?}",
            outs.len(),
            walls
                .iter()
                .map(|w| format!("{w:.4}"))
                .collect::<Vec<_>>()
                .join(" "),
            walls.iter().sum::<f64>(),
            cached
        );
    }
    let out = outs.last().expect("at least one frame");
    let images: Vec<&Image> = outs.iter().map(|o| &o.image).collect();
    for line in series_output::write_series_images(Some(&a.output), &a.series, &images, false)? {
        println!("{line}");
    }
    write_outputs(a, &out.report, &out.trace, out.report.nodes.len())
}

/// Writes the report (--report), the trace (--trace) and the timeline
/// (--timeline) of `ranks` ranks, saying each.
fn write_outputs<R: serde::Serialize>(
    a: &ClusterArgs,
    report: &R,
    trace: &SimTrace,
    ranks: usize,
) -> anyhow::Result<()> {
    if let Some(p) = &a.report {
        std::fs::write(p, serde_json::to_string_pretty(report)?)
            .with_context(|| format!("cannot write {}", p.display()))?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &a.trace {
        let f =
            std::fs::File::create(p).with_context(|| format!("cannot write {}", p.display()))?;
        trace.write_chrome_json(std::io::BufWriter::new(f))?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &a.timeline {
        crate::cluster::timeline::draw(trace, ranks, p)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}
