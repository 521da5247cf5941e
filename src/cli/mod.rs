//! The command line: one subcommand per task, each in its own file. Every
//! option documents its default; `pvrsim help COMMAND` shows it all.
//!
//! A thin frontend: clap definitions, arguments to jobs, printing. The work
//! is done by the job layer ([`crate::job`]: validation, output checks,
//! memory checks, render and cluster jobs), the benchmarks by
//! [`crate::bench`] and sweeps by [`crate::experiment`].

pub mod cluster;
pub mod demo;
mod demo_cluster;
pub mod fidelity;
pub mod generate;
pub mod generate_mesh;
pub mod info;
pub mod partition;
pub mod render;
pub mod scene;
pub mod splat;
pub mod sweep;
pub mod worker;

#[cfg(test)]
mod one_path_tests;

use clap::{Parser, Subcommand};

use crate::bench::{self, calibrate, splat_experiments};
/// The grid options of `cluster`, re-exported under the command's name.
pub use crate::job::cluster::grid as cluster_grid;
pub use crate::job::error_text;
pub(crate) use crate::job::{output, validate};
pub(crate) use crate::job::{plural, with_threads};

/// pvrsim: volume rendering of tetrahedral meshes (cell projection with early
/// ray termination) and regular grids (texture slicing, adaptive blocks,
/// splatting), and a simulator of the PC cluster that runs them.
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
    /// Render a scene to a PNG: meshes by cell projection, grids by texture slicing (or --renderer reference|slice2d|adaptive|splat).
    Render(render::RenderArgs),
    /// Render a grid scene by EWA splatting (--order axis|dda|sort|radix).
    Splat(splat::SplatArgs),
    /// The splatting experiments of docs/experiments/splatting.md (generated data; the 256^3 grid needs ../shared/data).
    SplatExperiments(splat_experiments::ExperimentArgs),
    /// Render on a simulated PC cluster (N nodes + manager; threads, processes, TCP): meshes with ERT, sharing and DLB, grids as bricks with ordered compositing and RLE; image, report, timeline.
    Cluster(Box<cluster::ClusterArgs>),
    /// Print a mesh's counts, bounds, fields and quality, or a grid's size, spacing, range and memory.
    Info(info::InfoArgs),
    /// Generate the built-in demo dataset, render it, write demo.png and a stats summary.
    Demo(demo::DemoArgs),
    /// Split a mesh into spatially coherent pieces, written as a .pvtu with one .vtu per piece.
    Partition(partition::PartitionArgs),
    /// Generate a test volume (hydrogen, marschner-lobb, resample, mesh-field, paper-*) as .nrrd with its scene .toml.
    Generate(generate::GenerateArgs),
    /// Time the renderers on the shared scenes (aorta meshes; --grids, --adaptive, --orderings, --lod-table).
    Bench(bench::BenchArgs),
    /// Run a config-driven parameter sweep: results.csv, summary.md and plots (see docs/sweeps.md); a progress bar on a terminal, one line per finished run when piped.
    Sweep(sweep::SweepArgs),
    /// Measure the node's unit costs (cost model) on this machine; --table1 fits the pentium4 profile.
    Calibrate(calibrate::CalibrateArgs),
    /// Measured beside modelled: the same frames on a real transport and on the virtual clock, per node and per phase (CPU and wall), with bands (--check).
    Fidelity(fidelity::FidelityArgs),
    /// Write a fitted scene for a mesh or a grid: camera framing the bounds, a transfer function over the field's range.
    Scene(scene::SceneArgs),
    /// Serve cluster frames as one worker process over TCP (see `cluster --transport`).
    Worker(worker::WorkerArgs),
    /// Look at a scene live in a web browser: prints `view: http://127.0.0.1:PORT/?token=TOKEN`; drag to orbit, edit the transfer function (in this process, or --nodes N on a cluster).
    View(Box<crate::view::ViewArgs>),
}

/// Logs to stderr at the level `-v` counts (warn, info, debug, trace;
/// `RUST_LOG` overrides). A second call in one process (the Python module
/// running the command line again) keeps the first subscriber.
pub fn init_logging(verbose: u8) {
    let level = match verbose {
        0 => "warn",
        1 => "info",
        2 => "debug",
        _ => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .try_init();
}

/// Runs the parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(a) => render::run(a),
        Command::Splat(a) => splat::run(a),
        Command::SplatExperiments(a) => splat_experiments::run(a),
        Command::Cluster(a) => cluster::run(*a),
        Command::Info(a) => info::run(a),
        Command::Demo(a) => demo::run(a),
        Command::Partition(a) => partition::run(a),
        Command::Generate(a) if a.kind == generate::Kind::MeshField => generate_mesh::run(a),
        Command::Generate(a) if a.kind == generate::Kind::Permuted => generate_mesh::permuted(a),
        Command::Generate(a) => generate::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Sweep(a) => sweep::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Fidelity(a) => fidelity::run(a),
        Command::Scene(a) => scene::run(a),
        Command::Worker(a) => worker::run(a),
        Command::View(a) => crate::view::run(*a),
    }
}
