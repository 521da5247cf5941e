//! # pvrsim
//!
//! Cell-projection parallel volume rendering of tetrahedral meshes with early
//! ray termination, regular-grid renderers, and a simulator of the PC
//! cluster that runs them.
//!
//! ## Layers
//!
//! Every room (top-level module) imports only rooms below it; no two rooms
//! import each other, and inside a room no two files do
//! (`docs/architecture.md` draws it;
//! `tests/architecture.rs` holds the table of allowed arrows and checks it:
//! `cargo test --release --test architecture -- --nocapture` prints the
//! arrows found):
//!
//! ```text
//! frontends   cli (clap, printing)   experiment (sweeps)   bench (benchmarks, calibration)
//!             view (the live viewer)   python/ (the Python module, its own crate)
//!                         \               |               /
//! job layer                job: typed jobs, validation, output and memory checks,
//!                          the cluster session (job::Session) and where its nodes run
//!                                          |
//! engine      cluster -> {manager, node, compositor, render, net}
//!             manager -> node   node -> {compositor, render, net}
//!             compositor -> {image, base}
//! renderers   render -> {data, scene, image, base}
//! data        data -> scene
//! base        scene, image, net, budget; base (Rect, Rgba, Segment, canonical); error, text
//! ```
//!
//! `cli` calls `job`, `bench`, `experiment` and `view`; `experiment`,
//! `bench`, `view` and the Python module call `job`; nothing below `job`
//! knows a frontend. Not every frontend path
//! goes through `job`: the benchmarks time one phase of the engine directly
//! (`bench -> render, node, compositor, cluster, net`), and `cli` reads data
//! and scenes for the commands that have no job of their own (`info`,
//! `scene`, `generate`, `demo`, `splat`, `worker`); each such arrow is named
//! with its reason in the table.
//!
//! ## Examples
//!
//! A render of a generated scene (the demo's hydrogen grid):
//!
//! ```
//! # fn main() -> anyhow::Result<()> {
//! let dir = std::env::temp_dir().join("pvrsim-doc-render");
//! std::fs::create_dir_all(&dir)?;
//! let (volume, scene) = pvrsim::data::demo_volume::demo_volume_and_scene("h.nrrd");
//! pvrsim::data::io::volume::write_nrrd(&volume, &dir.join("h.nrrd"), false, "doc")?;
//! std::fs::write(dir.join("h.toml"), scene)?;
//! let mut job = pvrsim::job::RenderJob::new(dir.join("h.toml"));
//! (job.width, job.height) = (Some(64), Some(64));
//! let out = job.run()?;
//! assert_eq!((out.image.width, out.image.height), (64, 64));
//! # Ok(()) }
//! ```
//!
//! A 4-node cluster frame on threads, with its report:
//!
//! ```
//! # fn main() -> anyhow::Result<()> {
//! use pvrsim::job::{args::transport::TransportKind, ClusterJob};
//! let mut job = ClusterJob::new("tests/data/aorta-small-view-b.toml");
//! job.nodes = 4;
//! job.net.transport = Some(TransportKind::Threads);
//! let out = job.run()?;
//! assert_eq!(out.report_json()["n_nodes"], 4);
//! println!("{}", out.summary());
//! # Ok(()) }
//! ```
//!
//! A two-point sweep (the integrator varies; options by flag name, each
//! point validated before the first runs):
//!
//! ```
//! # fn main() -> anyhow::Result<()> {
//! use pvrsim::job::{SweepCommand, SweepJob};
//! let rows = SweepJob::new(SweepCommand::Render, "tests/data/aorta-small-view-b.toml")
//!     .fixed("width", 64)
//!     .fixed("height", 64)
//!     .vary("integrator", ["exact", "midpoint"])
//!     .run()?;
//! assert_eq!(rows.len(), 2);
//! for r in &rows {
//!     println!("{:?}: {:.3} s", r.point.last(), r.outcome.as_ref().unwrap()["time_total_s"]);
//! }
//! # Ok(()) }
//! ```
//!
//! The same sweep from a config file, with its CSV, plots and summary, is
//! [`experiment::run_sweep`] (`pvrsim sweep CONFIG`). Benchmarks are typed
//! jobs too: [`bench::BenchJob`] (`pvrsim bench`'s options and defaults;
//! [`bench::BenchJob::cell_rows`] returns the measured rows).
#![warn(missing_docs)]

pub mod base;
pub mod bench;
pub mod budget;
pub mod cli;
pub mod cluster;
pub mod compositor;
pub mod data;
pub mod error;
pub mod experiment;
pub mod image;
pub mod job;
pub mod manager;
pub mod net;
pub mod node;
pub mod render;
pub mod scene;
pub mod text;
pub mod view;

pub use error::{Error, Result};
