//! The command line: one subcommand per task, each in its own file. Every
//! option documents its default; `pvrsim help COMMAND` shows it all.
//!
//! Shared by every command (new ones plug in the same way):
//! - [`validate`]: the one validation layer. Each command's args implement
//!   [`validate::Validate`]; ranges and the meaning of option combinations
//!   are decided there (errors say what to do, warnings what will happen);
//!   `sweep` runs the same checks on every run before the first.
//! - [`output`]: output paths checked before work (extension, writability,
//!   at most one new directory level), warnings, the broken-pipe stop.
//! - [`memory`]: a frame's memory, estimated and checked before allocating.
//! - [`compare`]: `render --compare`'s verdict and labelled strip.

pub mod bench;
pub mod bench_adaptive;
pub mod bench_grid;
pub mod bench_orderings;
pub mod bench_splat;
pub mod calibrate;
pub mod calibrate_network;
pub mod cluster;
pub mod cluster_ert;
pub mod cluster_grid;
pub mod compare;
pub mod demo;
mod demo_cluster;
pub mod generate;
pub mod generate_mesh;
pub mod info;
pub mod memory;
pub mod output;
pub mod render;
pub mod render_grid;
pub mod render_splat;
pub mod scene;
pub mod splat;
pub mod splat_experiments;
pub mod sweep;
pub mod transport_args;
pub mod validate;
pub mod worker;

use clap::{Parser, Subcommand};

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
    /// Generate a test volume (hydrogen, marschner-lobb, resample, mesh-field, paper-*) as .nrrd with its scene .toml.
    Generate(generate::GenerateArgs),
    /// Time the renderers on the shared scenes (aorta meshes; --grids, --adaptive, --orderings, --lod-table).
    Bench(bench::BenchArgs),
    /// Run a config-driven parameter sweep: results.csv, summary.md and plots (see docs/sweeps.md); a progress bar on a terminal, one line per finished run when piped.
    Sweep(sweep::SweepArgs),
    /// Measure the node's unit costs (cost model) on this machine; --table1 fits the pentium4 profile.
    Calibrate(calibrate::CalibrateArgs),
    /// Write a fitted scene for a mesh or a grid: camera framing the bounds, a transfer function over the field's range.
    Scene(scene::SceneArgs),
    /// Serve cluster frames as one worker process over TCP (see `cluster --transport`).
    Worker(worker::WorkerArgs),
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
        Command::Generate(a) => generate::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Sweep(a) => sweep::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Scene(a) => scene::run(a),
        Command::Worker(a) => worker::run(a),
    }
}

/// The text `main` prints for an error: `error: MSG` and one `caused by:`
/// line per cause, leaving out a cause whose text the line above already
/// ends with (a file error wrapped once would otherwise print twice).
pub fn error_text(e: &anyhow::Error) -> String {
    let mut s = format!("error: {e}\n");
    let mut last = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !last.ends_with(&c) {
            s.push_str(&format!("  caused by: {c}\n"));
        }
        last = c;
    }
    s
}

/// Warns when the scene's field is a vector field: it is rendered as its
/// magnitude (an extension of the scene contract, which names a scalar).
pub fn warn_field(input: &crate::render::RenderInput) {
    let name = &input.scene.data.field;
    if let Some(f) = input.mesh.fields.iter().find(|f| &f.name == name) {
        if f.components > 1 {
            output::warn(format!(
                "field \"{name}\" has {} components: rendering its magnitude |v| (range {:.4} .. {:.4})",
                f.components, input.range[0], input.range[1]
            ));
        }
    }
}

/// `n` and the noun, plural unless `n == 1` ("1 thread", "4 threads").
pub fn plural(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// Runs `f` in a rayon pool of `threads` threads (0: all cores).
pub fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> anyhow::Result<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    Ok(pool.install(f))
}
