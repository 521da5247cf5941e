//! `pvrsim cluster`: a scene on a simulated (or real) PC cluster. The options
//! and the work are the job layer's ([`crate::job::cluster`], re-exported
//! here; its one path is [`crate::job::cluster_job`]); this file checks the
//! outputs, runs the job and writes its files.

use anyhow::Context;

use crate::cluster::grid::GridOutcome;
use crate::image::Image;
pub use crate::job::cluster::*;
use crate::job::output::{self, prepare_output, OutputKind};
use crate::job::{ClusterResult, Valid};
use crate::net::SimTrace;

/// Runs `pvrsim cluster`: validates the options and checks every output
/// path first, then loads the scene once and runs it.
pub fn run(a: ClusterArgs) -> anyhow::Result<()> {
    // Under mpirun, ranks other than 0 serve a node and write nothing.
    if a.net.serve_mpi_worker(a.nodes)? {
        return Ok(());
    }
    let job = Valid::new(&a)?;
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
    let result = job.load()?.run_with_progress(|k, n| {
        if n > 1 {
            eprintln!(
                "frame {}/{n} done ({:.1} s)",
                k + 1,
                started.elapsed().as_secs_f64()
            );
        }
    })?;
    match &result {
        ClusterResult::Grid(outs) => write_grid(&a, outs)?,
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
            write_frames(&a, outs.iter().map(|o| &o.image))?;
            if let Some(m) = &a.series.movie {
                make_movie(&a, m, outs.iter().map(|o| &o.image))?;
            }
            let trace = if outs.len() > 1 {
                crate::cluster::series::joined_trace(outs)
            } else {
                out.trace.clone()
            };
            write_outputs(&a, &out.report, &trace, out.report.n_nodes)?;
            if let (Some(p), Some(series)) = (&a.series.series_csv, &out.report.series) {
                std::fs::write(p, series.csv())
                    .with_context(|| format!("cannot write {}", p.display()))?;
                println!("wrote {}", p.display());
            }
        }
    }
    print!("{}", result.summary());
    Ok(())
}

/// Writes the frames' images: every frame when `-o` has a `%d` pattern
/// (`out-%04d.png`), else the last one to `-o` (saying so when there were
/// more).
fn write_frames<'a>(
    a: &ClusterArgs,
    images: impl ExactSizeIterator<Item = &'a Image>,
) -> anyhow::Result<()> {
    let n = images.len();
    if crate::job::series_args::frame_path(&a.output, 0).is_some() {
        for (k, img) in images.enumerate() {
            let p = crate::job::series_args::frame_path(&a.output, k).expect("a pattern");
            img.save_png(&p)?;
            if k == 0 || k + 1 == n {
                println!("wrote {}", p.display());
            }
        }
        if n > 2 {
            println!("({n} frames written)");
        }
        return Ok(());
    }
    let last = images.last().expect("at least one frame");
    last.save_png(&a.output)?;
    if n > 1 {
        println!(
            "wrote {} (the last of {n} frames; -o out-%04d.png writes every frame)",
            a.output.display()
        );
    } else {
        println!("wrote {}", a.output.display());
    }
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
    write_frames(a, outs.iter().map(|o| &o.image))?;
    if let Some(m) = &a.series.movie {
        make_movie(a, m, outs.iter().map(|o| &o.image))?;
    }
    write_outputs(a, &out.report, &out.trace, out.report.nodes.len())
}

/// Makes `--movie` with ffmpeg from the frames (written to a private
/// folder first).
fn make_movie<'a>(
    a: &ClusterArgs,
    movie: &std::path::Path,
    images: impl Iterator<Item = &'a Image>,
) -> anyhow::Result<()> {
    /// The frames' folder, removed on every path.
    struct Frames(std::path::PathBuf);
    impl Drop for Frames {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let dir =
        Frames(std::env::temp_dir().join(format!("pvrsim-movie-{}-{nanos}", std::process::id())));
    std::fs::create_dir(&dir.0)
        .with_context(|| format!("cannot make {} for the movie's frames", dir.0.display()))?;
    for (k, img) in images.enumerate() {
        img.save_png(&dir.0.join(format!("f{k:06}.png")))?;
    }
    let fps = a.series.movie_fps.unwrap_or(10).to_string();
    let mut cmd = std::process::Command::new("ffmpeg");
    cmd.args(["-loglevel", "error", "-y", "-framerate", &fps, "-i"])
        .arg(dir.0.join("f%06d.png"));
    if movie
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mp4"))
    {
        // H.264 needs even sizes and a planar 4:2:0 format to play anywhere.
        cmd.args([
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "-pix_fmt",
            "yuv420p",
        ]);
    }
    let st = cmd
        .arg(movie)
        .status()
        .context("cannot run ffmpeg for --movie")?;
    anyhow::ensure!(
        st.success(),
        "ffmpeg failed making {} ({st})",
        movie.display()
    );
    println!("wrote {}", movie.display());
    Ok(())
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
