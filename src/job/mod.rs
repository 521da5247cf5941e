//! The job layer: everything pvrsim does, as typed, validated jobs that
//! the frontends (`cli`, `experiment`'s sweeps, `bench`) call. A job is a
//! set of options with the command line's defaults; running it returns
//! typed values (image, statistics, the summary lines the command line
//! prints, cluster report). Jobs print nothing on stdout; warnings go to
//! stderr, and the command line's own path (`run::render(.., quiet =
//! false)`) also writes `--compare`'s strip.
//!
//! - [`render`]: a render's options and outcome; [`run`] validates them
//!   once ([`Valid`]), loads the scene once and hands it to [`render_mesh`] (cell projection, the f64 reference)
//!   or [`render_grid`] (slicing, adaptive, [`render_splat`], the grid
//!   reference); [`grid_order`] is `--order`; [`compare`] is `--compare`'s
//!   verdict and strip.
//! - [`cluster`]: a cluster frame's options, of a mesh ([`cluster_mesh`];
//!   a `.pvtu` whose workers read their own pieces: [`cluster_pieces`]) or
//!   a grid ([`cluster_grid`], whose options are [`grid_args`]), or a
//!   series of frames ([`series_args`], [`series_steps`], [`series_output`]), on
//!   a transport ([`transport_args`]), with ERT modes ([`cluster_ert`]);
//!   [`cluster_job`] is its one path: validated once, the scene read once
//!   and its mesh, pieces or volume loaded ([`LoadedCluster`]), then run.
//! - [`render_loaded`]: a render whose data stays loaded ([`LoadedRender`]),
//!   frames with another camera, transfer function or size (the viewer).
//! - [`validate`]: the one validation layer. Each job implements
//!   [`validate::Validate`]; ranges and the meaning of option combinations
//!   are decided there (errors say what to do, warnings what will happen);
//!   sweeps run the same checks on every run before the first.
//! - [`option_rules`]: the options that only matter with another setting
//!   (structure, sharing, transport, clock, renderer, series), one table
//!   per command, refused or warned about by [`validate`].
//! - [`output`]: output paths checked before work (extension, writability,
//!   at most one new directory level), warnings, the broken-pipe stop.
//! - [`memory`]: a frame's memory, estimated and checked before allocating.
//! - [`api`]: the typed entry points [`RenderJob`] and [`ClusterJob`]
//!   (`new` with the command line's defaults, `from_options` by flag name,
//!   serde from a job file, `check`, `run`) and [`JobError`];
//! - [`sweep`]: [`SweepJob`], a sweep as a typed job (fixed and varying
//!   options by flag name, every point validated before the first runs,
//!   typed rows); the config-file sweep frontend runs its points here.
//! - [`scene_fit`]: a scene fitted to a data file (the data read as a
//!   [`crate::scene::fit::SceneSource`], the fitting [`crate::scene::fit`]'s).
//! - [`shared_args`]: options several commands share, declared once
//!   (`--ert`).
//! - [`options`]: options by flag name, the one mapping that job files,
//!   and sweeps share.
//!
//! The crate documentation has examples.

pub mod api;
pub mod cluster;
pub mod cluster_ert;
pub mod cluster_grid;
pub mod cluster_job;
pub mod cluster_mesh;
pub mod cluster_pieces;
pub mod compare;
pub mod grid_args;
pub mod grid_order;
pub mod memory;
pub mod nodes;
pub mod option_rules;
pub mod options;
pub mod output;
pub mod render;
pub mod render_grid;
pub mod render_loaded;
pub mod render_mesh;
pub mod render_splat;
pub mod run;
pub mod scene_fit;
pub mod series_args;
pub mod series_output;
pub mod series_steps;
pub mod session;
pub mod shared_args;
pub mod sweep;
pub mod transport_args;
pub mod validate;

pub use crate::text::plural;
pub use api::{ClusterJob, ClusterResult, JobError, RenderJob};
pub use cluster_job::LoadedCluster;
pub use render::RenderOutcome;
pub use render_loaded::{LoadedRender, ViewChange};
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
