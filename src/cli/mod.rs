//! The command line: one subcommand per task, each in its own file. Every
//! option documents its default; `pvrsim help COMMAND` shows it all.

pub mod bench;
pub mod calibrate;
pub mod cluster;
pub mod demo;
pub mod generate;
pub mod info;
pub mod render;
pub mod sweep;

use clap::{Parser, Subcommand};

/// pvrsim: cell-projection volume rendering of tetrahedral meshes with early
/// ray termination, and a simulator of the PC cluster that runs it.
///
/// Quick start: `pvrsim demo` generates a built-in dataset, renders it and
/// writes demo/demo.png. Then `pvrsim render demo/demo.toml -o out.png`.
/// Scenes follow the scene contract (TOML: data, camera, image, transfer);
/// see README.md.
#[derive(Debug, Parser)]
#[command(name = "pvrsim", version, about, long_about, propagate_version = true)]
pub struct Cli {
    /// Log more: -v info, -vv debug, -vvv trace (to stderr). RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    pub verbose: u8,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene to a PNG with the cell-projection or the reference renderer.
    Render(render::RenderArgs),
    /// Render on a simulated PC cluster (N nodes + manager): ERT, weak sharing, DLB, compositing; image, report, timeline.
    Cluster(cluster::ClusterArgs),
    /// Print a mesh file's counts, bounds, fields and mesh quality.
    Info(info::InfoArgs),
    /// Generate the built-in demo dataset, render it, write demo.png and a stats summary.
    Demo(demo::DemoArgs),
    /// Generate a test volume (hydrogen, marschner-lobb, resample) as .nrrd with its scene .toml.
    Generate(generate::GenerateArgs),
    /// Time the renderers on the shared aorta scenes (needs ../shared/data).
    Bench(bench::BenchArgs),
    /// Run a config-driven parameter sweep: results.csv, summary.md and plots (see docs/sweeps.md).
    Sweep(sweep::SweepArgs),
    /// Measure the node's unit costs (cost model) on this machine; --table1 fits the pentium4 profile.
    Calibrate(calibrate::CalibrateArgs),
}

/// Runs the parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(a) => render::run(a),
        Command::Cluster(a) => cluster::run(a),
        Command::Info(a) => info::run(a),
        Command::Demo(a) => demo::run(a),
        Command::Generate(a) => generate::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Sweep(a) => sweep::run(a),
        Command::Calibrate(a) => calibrate::run(a),
    }
}

/// Runs `f` in a rayon pool of `threads` threads (0: all cores).
pub fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> anyhow::Result<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    Ok(pool.install(f))
}
