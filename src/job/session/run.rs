//! A loaded cluster job run into a [`ClusterResult`]: a mesh scene's frames
//! on one [`Session`] (every transport, MPI included), a grid scene's frames on its own path
//! ([`crate::job::cluster::grid`]). Each frame is handed to `progress` as it
//! ends, so that a frontend can write it before the next one starts.

use crate::cluster::series::MeasuredFrame;
use crate::cluster::series::{Coherence, Step};
use crate::cluster::ClusterOutcome;
use crate::job::api::ClusterResult;
use crate::job::cluster::load::LoadedCluster;
use crate::job::cluster::mesh::MeshFrame;
use crate::job::cluster::ClusterArgs;

use super::{coherence, Session};

impl LoadedCluster<'_> {
    /// Runs the frame(s), writing nothing.
    pub fn run(self) -> anyhow::Result<ClusterResult> {
        self.run_with_progress(|_, _, _| {})
    }

    /// [`Self::run`], calling `progress(frame, frames, outcome)` as each
    /// frame of a mesh scene ends.
    pub fn run_with_progress(
        self,
        progress: impl FnMut(usize, usize, &ClusterOutcome),
    ) -> anyhow::Result<ClusterResult> {
        Ok(match self {
            LoadedCluster::Mesh(a, f) => ClusterResult::Mesh(run_mesh(a, *f, progress)?),
            LoadedCluster::Grid(a, f) => {
                ClusterResult::Grid(crate::job::cluster::grid::run(a, *f)?)
            }
            LoadedCluster::Pieces(a, f) => {
                let steps = f.steps.clone();
                let start = resume_at(a, steps.len())?;
                let series = a.series.is_series();
                let program = a.net.worker_program()?;
                let session = Session::from_loaded(LoadedCluster::Pieces(a, f), &program)?;
                ClusterResult::Mesh(run_series(
                    session,
                    &steps,
                    start,
                    series,
                    Coherence::Off,
                    progress,
                )?)
            }
        })
    }
}

/// A mesh job's frames on a session (under `--transport mpi`, on the MPI
/// job's ranks).
fn run_mesh(
    a: &ClusterArgs,
    f: MeshFrame,
    progress: impl FnMut(usize, usize, &ClusterOutcome),
) -> anyhow::Result<Vec<ClusterOutcome>> {
    let series = a.series.is_series();
    let coherence = coherence(a, f.remote, &f.cfg);
    let start = resume_at(a, f.steps.len())?;
    let first = f.steps[start].clone();
    let program = a.net.worker_program()?;
    let steps = f.steps;
    let session = Session::of_mesh(a, f.inputs, f.cfg, f.remote, coherence, first, &program)?;
    run_series(session, &steps, start, series, coherence, progress)
}

/// The first frame to render: 0, or with `--resume` the first whose file
/// is missing (an error when none is).
fn resume_at(a: &ClusterArgs, frames: usize) -> anyhow::Result<usize> {
    let start = a.series.resume_at(&a.output, frames)?;
    anyhow::ensure!(
        start < frames,
        "--resume: all {frames} frames of the series are on disk already ({} and on)",
        crate::job::series::args::frame_path(&a.output, 0).map_or_else(
            || a.output.display().to_string(),
            |p| p.display().to_string()
        )
    );
    if start > 0 {
        eprintln!("resuming at frame {start} of {frames} (frames 0..{start} are on disk)");
    }
    Ok(start)
}

/// Runs one frame per step from `start` on `session`, then closes it;
/// with more than one frame (`series`), the last frame's report carries
/// the series section of the frames run
/// ([`crate::cluster::series::report`]).
pub fn run_series(
    mut session: Session,
    steps: &[Step],
    start: usize,
    series: bool,
    coherence: Coherence,
    mut progress: impl FnMut(usize, usize, &ClusterOutcome),
) -> anyhow::Result<Vec<ClusterOutcome>> {
    let n = steps.len();
    let size = (session.scene.image.width, session.scene.image.height);
    let mut outs = Vec::with_capacity(n);
    let mut rows = Vec::with_capacity(n);
    let mut measured = true;
    for (f, step) in steps.iter().enumerate().skip(start) {
        crate::base::cancel::checkpoint();
        let frame = session.run_step(step, size).map_err(|e| match n {
            1 => e,
            _ => e.context(format!("frame {f} of {n}")),
        })?;
        match frame.bytes {
            Some((bytes, cells_bytes)) => rows.push(MeasuredFrame {
                frame_s: frame.wall_s,
                bytes,
                cells_bytes,
                compress_s: frame.compress_s,
            }),
            None => measured = false,
        }
        progress(f, n, &frame.outcome);
        outs.push(frame.outcome);
    }
    session.close()?;
    if series {
        let rows = measured.then_some(rows.as_slice());
        let s = crate::cluster::series::report(&outs, &steps[start..], rows, coherence);
        if let Some(last) = outs.last_mut() {
            last.report.series = Some(s);
        }
    }
    Ok(outs)
}
