//! A sweep as a typed job: one command (`render` or `cluster`), options
//! fixed for every run, options that vary (their cartesian product, the
//! first varying slowest) and repetitions; every point is a [`RenderJob`]
//! or a [`ClusterJob`] built by flag name, all of them validated before the
//! first runs. Running returns one typed row per run; the config-file
//! frontend (`experiment::run_sweep`: CSV, plots, resume, progress) is built
//! on the same point runner, [`run_point`].

use std::path::PathBuf;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::api::{ClusterJob, ClusterResult, JobError, RenderJob};
use super::args::by_name::ParamValue;

/// The command each point of a sweep runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SweepCommand {
    /// `pvrsim render`: one image per point.
    Render,
    /// `pvrsim cluster`: one cluster frame (or series) per point.
    Cluster,
}

impl SweepCommand {
    /// The subcommand's name, as a sweep config's `command` spells it.
    pub fn name(self) -> &'static str {
        match self {
            SweepCommand::Render => "render",
            SweepCommand::Cluster => "cluster",
        }
    }

    /// The command named `name`, if sweeps can run it.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "render" => Some(SweepCommand::Render),
            "cluster" => Some(SweepCommand::Cluster),
            _ => None,
        }
    }
}

/// Options by flag name: `("ert", Float(0.9))`, `("scene", Str(..))`.
pub type Options = Vec<(String, ParamValue)>;

/// A sweep: what every run shares, what varies, how often each point runs.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SweepJob {
    /// The command of every run.
    pub command: SweepCommand,
    /// The scene of every run (a path, as `pvrsim render SCENE` takes it).
    pub scene: PathBuf,
    /// Options of every run, by flag name (a job file's `[fixed]` table).
    #[serde(default, with = "ordered::fixed")]
    pub fixed: Vec<(String, ParamValue)>,
    /// Options that vary, by flag name, with their values (a job file's
    /// `[vary]` table, in order: the first varies slowest).
    #[serde(default, with = "ordered::vary")]
    pub vary: Vec<(String, Vec<ParamValue>)>,
    /// Runs per point (default 1).
    #[serde(default = "one")]
    pub repetitions: usize,
}

fn one() -> usize {
    1
}

/// One run of a sweep.
#[derive(Debug, Clone)]
pub struct SweepRow {
    /// The point's options (the fixed ones, then the varying ones).
    pub point: Options,
    /// Which repetition of the point (0-based).
    pub repetition: usize,
    /// The run's wall time, seconds.
    pub wall_s: f64,
    /// The run's statistics (render: `--stats`; cluster: the flat report),
    /// or why it failed.
    pub outcome: Result<serde_json::Value, String>,
}

impl SweepJob {
    /// A sweep of `command` over `scene` with no option fixed or varied yet.
    pub fn new(command: SweepCommand, scene: impl Into<PathBuf>) -> Self {
        SweepJob {
            command,
            scene: scene.into(),
            fixed: Vec::new(),
            vary: Vec::new(),
            repetitions: 1,
        }
    }

    /// Fixes option `name` (flag name, `ert_table` or `ert-table`) to `value`.
    pub fn fixed(mut self, name: &str, value: impl Into<ParamValue>) -> Self {
        self.fixed.push((name.replace('-', "_"), value.into()));
        self
    }

    /// Varies option `name` over `values`.
    pub fn vary<V: Into<ParamValue>>(
        mut self,
        name: &str,
        values: impl IntoIterator<Item = V>,
    ) -> Self {
        let values = values.into_iter().map(Into::into).collect();
        self.vary.push((name.replace('-', "_"), values));
        self
    }

    /// Every point's options, the first varying option slowest. A varying
    /// option with no value gives no point.
    pub fn points(&self) -> Vec<Options> {
        let mut base = vec![(
            "scene".to_string(),
            ParamValue::Str(self.scene.display().to_string()),
        )];
        base.extend(self.fixed.iter().cloned());
        let mut points = vec![base];
        for (name, values) in &self.vary {
            points = points
                .into_iter()
                .flat_map(|p| {
                    values.iter().map(move |v| {
                        let mut q = p.clone();
                        q.retain(|(k, _)| k != name);
                        q.push((name.clone(), v.clone()));
                        q
                    })
                })
                .collect();
        }
        points
    }

    /// Validates every point as its job (the command line's checks); the
    /// error names the point. Returns the warnings, once each.
    pub fn check(&self) -> Result<Vec<String>, JobError> {
        if self.repetitions == 0 {
            return Err(JobError::Invalid(anyhow::anyhow!(
                "repetitions = 0: a sweep runs each point at least once"
            )));
        }
        let mut warnings = Vec::new();
        for point in self.points() {
            let w = check_point(self.command, &point).map_err(|e| in_point(e, &point))?;
            for x in w {
                if !warnings.contains(&x) {
                    warnings.push(x);
                }
            }
        }
        Ok(warnings)
    }

    /// Checks every point, then runs each `repetitions` times, in order. A
    /// run that fails is a row with its error; the sweep goes on.
    pub fn run(&self) -> Result<Vec<SweepRow>, JobError> {
        self.check()?;
        let mut rows = Vec::new();
        for point in self.points() {
            for repetition in 0..self.repetitions {
                let t = Instant::now();
                let outcome = run_point(self.command, &point).map_err(|e| e.to_string());
                rows.push(SweepRow {
                    point: point.clone(),
                    repetition,
                    wall_s: t.elapsed().as_secs_f64(),
                    outcome,
                });
            }
        }
        Ok(rows)
    }
}

/// The point's options as text, for messages: `ert=0.9, tile=32`.
fn describe(point: &Options) -> String {
    point
        .iter()
        .filter(|(k, _)| k != "scene")
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn in_point(e: JobError, point: &Options) -> JobError {
    let at = describe(point);
    match e {
        JobError::Options(c) => JobError::Invalid(anyhow::anyhow!(
            "sweep point {at}: {}",
            super::args::by_name::clap_message(&c)
        )),
        JobError::Invalid(e) => JobError::Invalid(anyhow::anyhow!("sweep point {at}: {e:#}")),
        JobError::Failed(e) => JobError::Failed(e.context(format!("sweep point {at}"))),
    }
}

/// Builds the point's job by flag name and validates it: the warnings.
pub fn check_point(command: SweepCommand, point: &Options) -> Result<Vec<String>, JobError> {
    match command {
        SweepCommand::Render => RenderJob::from_options(point)?.check(),
        SweepCommand::Cluster => ClusterJob::from_options(point)?.check(),
    }
}

/// Runs one point: a render's statistics (as `--stats` writes them), or a
/// cluster frame's report without the per-node array and the per-exchange
/// list (grid reports also without their rounds), to keep rows flat.
pub fn run_point(command: SweepCommand, point: &Options) -> Result<serde_json::Value, JobError> {
    match command {
        SweepCommand::Render => Ok(RenderJob::from_options(point)?.run()?.stats),
        SweepCommand::Cluster => Ok(flat_report(&ClusterJob::from_options(point)?.run()?)),
    }
}

/// A cluster frame's report as one sweep row: without the per-node array
/// and the per-exchange list (grid reports also without their rounds).
pub fn flat_report(out: &ClusterResult) -> serde_json::Value {
    let mut v = out.report_json();
    if let (ClusterResult::Grid(_), Some(o)) = (out, v.as_object_mut()) {
        o.remove("rounds");
    }
    if let Some(o) = v.as_object_mut() {
        o.remove("nodes");
        if let Some(t) = o.get_mut("t_share").and_then(|t| t.as_object_mut()) {
            t.remove("per_exchange_s");
        }
        // A series keeps its totals (`series.fps`, ...), not its rows.
        if let Some(s) = o.get_mut("series").and_then(|s| s.as_object_mut()) {
            s.remove("frames");
        }
    }
    v
}

/// `[fixed]` and `[vary]` as ordered tables (`ert = 0.9`, `tile = [16, 32]`).
mod ordered {
    use serde::{de::Error, Deserialize, Deserializer, Serialize, Serializer};

    use super::ParamValue;

    fn to_toml(v: &ParamValue) -> toml::Value {
        match v {
            ParamValue::Bool(b) => toml::Value::Boolean(*b),
            ParamValue::Int(i) => toml::Value::Integer(*i),
            ParamValue::Float(x) => toml::Value::Float(*x),
            ParamValue::Str(s) => toml::Value::String(s.clone()),
        }
    }

    pub mod fixed {
        use super::*;

        pub fn serialize<S: Serializer>(
            v: &[(String, ParamValue)],
            s: S,
        ) -> Result<S::Ok, S::Error> {
            let t: toml::Table = v.iter().map(|(k, x)| (k.clone(), to_toml(x))).collect();
            t.serialize(s)
        }

        pub fn deserialize<'de, D: Deserializer<'de>>(
            d: D,
        ) -> Result<Vec<(String, ParamValue)>, D::Error> {
            toml::Table::deserialize(d)?
                .iter()
                .map(|(k, v)| {
                    Ok((
                        k.clone(),
                        ParamValue::from_toml(v, k).map_err(D::Error::custom)?,
                    ))
                })
                .collect()
        }
    }

    pub mod vary {
        use super::*;

        pub fn serialize<S: Serializer>(
            v: &[(String, Vec<ParamValue>)],
            s: S,
        ) -> Result<S::Ok, S::Error> {
            let t: toml::Table = v
                .iter()
                .map(|(k, xs)| {
                    (
                        k.clone(),
                        toml::Value::Array(xs.iter().map(to_toml).collect()),
                    )
                })
                .collect();
            t.serialize(s)
        }

        pub fn deserialize<'de, D: Deserializer<'de>>(
            d: D,
        ) -> Result<Vec<(String, Vec<ParamValue>)>, D::Error> {
            let mut out = Vec::new();
            for (k, v) in toml::Table::deserialize(d)? {
                let values = match &v {
                    toml::Value::Array(xs) => xs
                        .iter()
                        .enumerate()
                        .map(|(i, x)| ParamValue::from_toml(x, &format!("vary.{k}[{i}]")))
                        .collect::<Result<Vec<_>, _>>(),
                    x => ParamValue::from_toml(x, &format!("vary.{k}")).map(|p| vec![p]),
                }
                .map_err(D::Error::custom)?;
                out.push((k, values));
            }
            Ok(out)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_are_the_product_first_option_slowest() {
        let job = SweepJob::new(SweepCommand::Render, "s.toml")
            .fixed("width", 64)
            .vary("ert", [0.9, 1.0])
            .vary("tile", [16, 32, 64]);
        let p = job.points();
        assert_eq!(p.len(), 6);
        let text: Vec<String> = p.iter().map(describe).collect();
        assert_eq!(text[0], "width=64, ert=0.9, tile=16");
        assert_eq!(text[2], "width=64, ert=0.9, tile=64");
        assert_eq!(text[3], "width=64, ert=1, tile=16");
        assert!(p.iter().all(|q| q[0].0 == "scene"));
    }

    #[test]
    fn a_varied_option_replaces_the_fixed_one_and_no_values_means_no_points() {
        let job = SweepJob::new(SweepCommand::Render, "s.toml")
            .fixed("tile", 8)
            .vary("tile", [16]);
        assert_eq!(describe(&job.points()[0]), "tile=16");
        let none = SweepJob::new(SweepCommand::Render, "s.toml").vary::<i64>("tile", []);
        assert!(none.points().is_empty());
    }

    #[test]
    fn a_bad_point_is_refused_before_any_run_and_named() {
        let job = SweepJob::new(SweepCommand::Render, "tests/data/aorta-small-view-b.toml")
            .vary("ert", [0.9, 7.0]);
        let e = job.run().expect_err("ert = 7 is out of range");
        let text = format!("{e:#}");
        assert!(text.contains("sweep point ert=7"), "{text}");
        assert!(text.contains("--ert"), "{text}");
        let e = SweepJob::new(SweepCommand::Cluster, "x.toml")
            .fixed("no_such_option", true)
            .check()
            .expect_err("unknown option");
        assert!(format!("{e:#}").contains("no-such-option"), "{e:#}");
    }

    #[test]
    fn serde_round_trip_of_a_job_file() {
        let text = r#"command = "cluster"
scene = "s.toml"
[fixed]
nodes = 4
[vary]
tile = [64, 16]
ert = [0.9, 1.0, 0.5]
"#;
        let job: SweepJob = toml::from_str(text).expect("parses");
        assert_eq!(job.command, SweepCommand::Cluster);
        assert_eq!(job.repetitions, 1);
        assert_eq!(job.points().len(), 6);
        assert_eq!(describe(&job.points()[1]), "nodes=4, tile=64, ert=1");
        let again: SweepJob =
            toml::from_str(&toml::to_string(&job).expect("writes")).expect("reads back");
        assert_eq!(again.points(), job.points());
        let bad = toml::from_str::<SweepJob>(
            "command = \"render\"\nscene = \"s\"\n[vary]\nert = [[1]]\n",
        );
        assert!(format!("{}", bad.unwrap_err()).contains("vary.ert[0]"));
    }
}
