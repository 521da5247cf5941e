//! The job layer: everything pvrsim does, as typed, validated jobs that
//! the frontends (`cli`, `experiment`'s sweeps, `bench`) call. A job is a
//! set of options with the command line's defaults; running it returns
//! typed values (image, statistics, the summary lines the command line
//! prints, cluster report). Jobs print nothing on stdout; warnings go to
//! stderr, and the command line's own path (`run::render(.., quiet =
//! false)`) also writes `--compare`'s strip.
//!
//! The rooms, by folder:
//!
//! - [`render`]: a render's options and outcome ([`render::mesh`]: cell
//!   projection and the f64 reference; [`render::grid`]: slicing,
//!   adaptive, [`render::splat`], the grid reference; [`render::loaded`]:
//!   a render whose data stays loaded, [`LoadedRender`], frames with
//!   another camera, transfer function or size, for the viewer); [`run`]
//!   validates them once ([`Valid`]) and loads the scene once;
//!   [`grid_order`] is `--order`; [`compare`] is `--compare`'s verdict and
//!   strip.
//! - [`cluster`]: a cluster job's options and its one path
//!   ([`cluster::load`]: validated once, the scene read once, its mesh
//!   ([`cluster::mesh`]), pieces ([`cluster::pieces`]: a `.pvtu` whose
//!   workers read their own) or volume ([`cluster::grid`]) loaded,
//!   [`LoadedCluster`]), with ERT modes ([`cluster::ert`]).
//! - [`session`]: a cluster that stays up between frames ([`Session`]) on
//!   every transport; where its nodes run (spawned processes, TCP workers,
//!   MPI ranks) is [`nodes`]'s.
//! - [`series`]: frames of a series: options ([`series::args`]), steps
//!   ([`series::steps`]), each frame's files as it completes
//!   ([`series::output`]).
//! - [`args`]: option groups several commands share: the transport
//!   ([`args::transport`]), the grid renderers ([`args::grid`]), `--ert`
//!   ([`args::shared`]); options by flag name, the one mapping that job
//!   files and sweeps share ([`args::by_name`]).
//! - [`rules`]: the options that only matter with another setting, one
//!   table per command, checked by [`validate`].
//! - [`validate`]: the one validation layer. Each job implements
//!   [`validate::Validate`]; ranges and the meaning of option combinations
//!   are decided there (errors say what to do, warnings what will happen);
//!   sweeps run the same checks on every run before the first.
//! - [`output`]: output paths checked before work (extension, writability,
//!   missing folders created), warnings, the broken-pipe stop.
//! - [`memory`]: a frame's memory, estimated and checked before allocating.
//! - [`api`]: the typed entry points [`RenderJob`] and [`ClusterJob`]
//!   (`new` with the command line's defaults, `from_options` by flag name,
//!   serde from a job file, `check`, `run`) and [`JobError`];
//! - [`sweep`]: [`SweepJob`], a sweep as a typed job (fixed and varying
//!   options by flag name, every point validated before the first runs,
//!   typed rows); the config-file sweep frontend runs its points here.
//! - [`scene_fit`]: a scene fitted to a data file (the data read as a
//!   [`crate::scene::fit::SceneSource`], the fitting [`crate::scene::fit`]'s).
//!
//! The crate documentation has examples.

pub mod api;
pub mod args;
pub mod cluster;
pub mod compare;
pub mod grid_order;
pub mod memory;
pub mod nodes;
pub mod output;
pub mod render;
pub mod rules;
pub mod run;
pub mod scene_fit;
pub mod series;
pub mod session;
pub mod sweep;
pub mod validate;

pub use crate::text::plural;
pub use api::{ClusterJob, ClusterResult, JobError, RenderJob};
pub use cluster::load::LoadedCluster;
pub use render::loaded::{LoadedRender, ViewChange};
pub use render::RenderOutcome;
pub use session::{FrameRequest, Session};
pub use sweep::{SweepCommand, SweepJob, SweepRow};
pub use validate::Valid;

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

/// An error's chain on one line, `outer: cause: ...`, as `{e:#}` but
/// naming each cause once: a cause whose text the message before it
/// already ends with (an I/O error that `path: error` quotes) is left out.
/// The Python module's exceptions carry this text.
pub fn error_line(e: &anyhow::Error) -> String {
    let mut s = e.to_string();
    let mut last = s.clone();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !last.ends_with(&c) {
            s.push_str(": ");
            s.push_str(&c);
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

/// Reads a scene file (the one read of a job's scene), saying which.
pub fn load_scene(path: &std::path::Path) -> anyhow::Result<crate::scene::Scene> {
    use anyhow::Context;
    crate::scene::Scene::load(path).with_context(|| format!("cannot load scene {}", path.display()))
}

/// Runs `f` in a rayon pool of `threads` threads (0: all cores).
pub fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> anyhow::Result<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    Ok(pool.install(f))
}

#[cfg(test)]
mod tests {
    #[test]
    fn error_line_names_each_cause_once() {
        // A cause that quotes its source, as `path: error` does.
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file (os error 2)");
        let e = anyhow::Error::new(io)
            .context("m.vtk: No such file (os error 2)")
            .context("cannot read m.vtk");
        assert_eq!(
            super::error_line(&e),
            "cannot read m.vtk: m.vtk: No such file (os error 2)"
        );
        assert_eq!(format!("{e:#}").matches("No such file").count(), 2);
    }
}
