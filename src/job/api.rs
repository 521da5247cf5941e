//! The typed entry points: a job is a command's options with the command
//! line's defaults ([`RenderJob::new`], [`ClusterJob::new`]), built from a
//! table of options by flag name (a job file, a sweep point:
//! [`super::args::by_name`]), checked by the validation layer and run into typed
//! values. Errors say which stage refused the job ([`JobError`]).

use std::path::PathBuf;

use serde::de::{Deserialize, Deserializer};

use super::args::by_name::{self as options, ParamValue};
use super::cluster::ClusterArgs;
use super::render::{RenderArgs, RenderOutcome};
use super::validate;
use crate::cluster::grid::GridOutcome;
use crate::cluster::ClusterOutcome;
use crate::image::Image;

/// A render job: a scene, a renderer and its options, exactly
/// `pvrsim render`'s (same names, defaults and checks).
pub type RenderJob = RenderArgs;

/// A cluster job: a scene on N nodes (a frame, or a series of
/// `series.frames` frames), on a transport (`net.transport`: simulated by default, threads,
/// processes, TCP, MPI), exactly `pvrsim cluster`'s options.
pub type ClusterJob = ClusterArgs;

/// Why a job did not run or did not finish.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The options do not parse: an unknown name or a malformed value
    /// (clap's message, one line).
    #[error("{}", options::clap_message(.0))]
    Options(Box<clap::Error>),
    /// The options parse but the validation layer refuses them (a range, a
    /// combination); the message says what to do.
    #[error("{0}")]
    Invalid(anyhow::Error),
    /// The job ran and failed: a missing or malformed file, too little
    /// memory, a transport failure.
    #[error("{0:#}")]
    Failed(anyhow::Error),
}

impl From<clap::Error> for JobError {
    fn from(e: clap::Error) -> Self {
        JobError::Options(Box::new(e))
    }
}

/// The options of a command with its defaults and `scene` as the scene.
fn defaults<T: clap::Args + clap::FromArgMatches>(name: &'static str) -> T {
    options::parse(name, &["scene".to_string()]).expect("the defaults parse")
}

impl RenderArgs {
    /// A render of `scene` with `pvrsim render`'s defaults.
    pub fn new(scene: impl Into<PathBuf>) -> Self {
        let mut job: Self = defaults("pvrsim render");
        job.scene = scene.into();
        job
    }

    /// A render from options by flag name (`scene` is the positional one).
    pub fn from_options(options: &[(String, ParamValue)]) -> Result<Self, JobError> {
        Ok(options::from_options("pvrsim render", &["scene"], options)?)
    }

    /// The validation layer's verdict: the warnings, or why it is refused.
    pub fn check(&self) -> Result<Vec<String>, JobError> {
        validate::check(self).map_err(JobError::Invalid)
    }

    /// Renders, writing no file and printing nothing: the image and every
    /// statistic (as `--stats` writes them).
    pub fn run(&self) -> Result<RenderOutcome, JobError> {
        let job = validate::Valid::new(self).map_err(JobError::Invalid)?;
        job.run(true).map_err(JobError::Failed)
    }
}

/// What a cluster job produced.
pub enum ClusterResult {
    /// The frames of a mesh scene (one unless `series.frames`), in order;
    /// with several, the last frame's report has the `series` section.
    Mesh(Vec<ClusterOutcome>),
    /// The frames of a grid scene (one unless `series.frames`), in order.
    Grid(Vec<GridOutcome>),
}

impl ClusterResult {
    /// The (last) frame's image.
    pub fn image(&self) -> &Image {
        match self {
            ClusterResult::Mesh(f) => &f.last().expect("at least one frame").image,
            ClusterResult::Grid(f) => &f.last().expect("at least one frame").image,
        }
    }

    /// Every frame's image, in order.
    pub fn images(&self) -> Vec<&Image> {
        match self {
            ClusterResult::Mesh(f) => f.iter().map(|o| &o.image).collect(),
            ClusterResult::Grid(f) => f.iter().map(|o| &o.image).collect(),
        }
    }

    /// The (last) frame's report as `--report` writes it.
    pub fn report_json(&self) -> serde_json::Value {
        match self {
            ClusterResult::Mesh(f) => serde_json::to_value(&f.last().expect("a frame").report),
            ClusterResult::Grid(f) => serde_json::to_value(&f.last().expect("a frame").report),
        }
        .expect("reports serialize")
    }

    /// The timeline `--trace` and `--timeline` write, and its rank count:
    /// a mesh series' frames laid end to end
    /// ([`crate::cluster::series::joined_trace`]), else the (last) frame's.
    pub fn trace(&self) -> (std::borrow::Cow<'_, crate::net::SimTrace>, usize) {
        use std::borrow::Cow;
        match self {
            ClusterResult::Mesh(f) => {
                let last = f.last().expect("a frame");
                let trace = if f.len() > 1 {
                    Cow::Owned(crate::cluster::series::joined_trace(f))
                } else {
                    Cow::Borrowed(&last.trace)
                };
                (trace, last.report.n_nodes)
            }
            ClusterResult::Grid(f) => {
                let last = f.last().expect("a frame");
                (Cow::Borrowed(&last.trace), last.report.nodes.len())
            }
        }
    }

    /// Every frame's report as `--report` writes it, in order.
    pub fn frame_reports_json(&self) -> Vec<serde_json::Value> {
        match self {
            ClusterResult::Mesh(f) => f
                .iter()
                .map(|o| serde_json::to_value(&o.report))
                .collect::<Vec<_>>(),
            ClusterResult::Grid(f) => f.iter().map(|o| serde_json::to_value(&o.report)).collect(),
        }
        .into_iter()
        .map(|r| r.expect("reports serialize"))
        .collect()
    }

    /// The (last) frame's report as text, as `pvrsim cluster` prints it.
    pub fn summary(&self) -> String {
        match self {
            ClusterResult::Mesh(f) => {
                let r = &f.last().expect("a frame").report;
                let mut s = crate::cluster::report::summary(r);
                if let Some(series) = &r.series {
                    s.push_str(&series.line());
                    s.push('\n');
                }
                s
            }
            ClusterResult::Grid(f) => {
                crate::cluster::grid::summary(&f.last().expect("a frame").report)
            }
        }
    }
}

impl ClusterArgs {
    /// A cluster run of `scene` with `pvrsim cluster`'s defaults.
    pub fn new(scene: impl Into<PathBuf>) -> Self {
        let mut job: Self = defaults("pvrsim cluster");
        job.scene = scene.into();
        job
    }

    /// A cluster run from options by flag name (`scene` is positional).
    pub fn from_options(options: &[(String, ParamValue)]) -> Result<Self, JobError> {
        Ok(options::from_options(
            "pvrsim cluster",
            &["scene"],
            options,
        )?)
    }

    /// The validation layer's verdict: the warnings, or why it is refused.
    pub fn check(&self) -> Result<Vec<String>, JobError> {
        validate::check(self).map_err(JobError::Invalid)
    }

    /// Runs the frame(s), writing no file: images, reports, timelines.
    pub fn run(&self) -> Result<ClusterResult, JobError> {
        let job = validate::Valid::new(self).map_err(JobError::Invalid)?;
        job.load()
            .and_then(|loaded| loaded.run())
            .map_err(JobError::Failed)
    }
}

/// A job file is a table of options by flag name, the same table a sweep's
/// `fixed` section holds: `scene = "s.toml"`, `ert = 0.9`, `compare = true`.
fn table<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<(String, ParamValue)>, D::Error> {
    let m = std::collections::BTreeMap::<String, ParamValue>::deserialize(d)?;
    Ok(m.into_iter().collect())
}

impl<'de> Deserialize<'de> for RenderArgs {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let t = table(d)?;
        Self::from_options(&t).map_err(serde::de::Error::custom)
    }
}

impl<'de> Deserialize<'de> for ClusterArgs {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let t = table(d)?;
        Self::from_options(&t).map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_job_file_is_options_by_flag_name() {
        let job: RenderJob =
            toml::from_str("scene = \"s.toml\"\nert = 0.9\ncompare = true\nert_table = 20\n")
                .unwrap();
        assert_eq!(job.scene, PathBuf::from("s.toml"));
        assert_eq!(
            (job.ert.threshold, job.compare, job.ert_table),
            (0.9, true, Some(20))
        );
        let defaults = RenderJob::new("s.toml");
        assert_eq!(defaults.output, PathBuf::from("out.png"));
        assert!(!defaults.compare);
        let e = toml::from_str::<RenderJob>("scene = \"s.toml\"\nert_tabel = 3\n").unwrap_err();
        assert!(e.to_string().contains("--ert-tabel"), "{e}");
    }

    #[test]
    fn validation_and_parsing_errors_are_told_apart() {
        let mut job = ClusterJob::new("s.toml");
        job.nodes = 0;
        assert!(matches!(job.check(), Err(JobError::Invalid(_))));
        let opts = [("nodes".to_string(), ParamValue::Str("four".into()))];
        assert!(matches!(
            ClusterJob::from_options(&opts),
            Err(JobError::Options(_))
        ));
    }
}
