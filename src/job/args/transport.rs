//! The transport options of `pvrsim cluster` (flattened into its
//! arguments): where the nodes run and how they are reached. Parsing and
//! checking only; the nodes are started and reached by
//! [`crate::job::nodes`].

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context;
use clap::Args;

use crate::cluster::{ClockKind, ClusterConfig};
use crate::net::tcp::TcpOptions;

/// Where the nodes run (`--transport`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TransportKind {
    /// Threads of this process on channels (the same as `--clock wall`).
    Threads,
    /// One child process per node on loopback TCP, with a fresh token.
    Processes,
    /// One `pvrsim worker` per node at --workers or --hostfile addresses.
    Tcp,
    /// Under `mpirun -n N+1`: MPI rank 0 the coordinator, ranks 1..N the
    /// nodes (needs a build with `--features mpi`).
    Mpi,
}

impl TransportKind {
    /// The name `--transport` takes.
    pub fn name(self) -> &'static str {
        match self {
            TransportKind::Threads => "threads",
            TransportKind::Processes => "processes",
            TransportKind::Tcp => "tcp",
            TransportKind::Mpi => "mpi",
        }
    }
}

/// What happens when a worker fails mid-frame (`--on-failure`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OnFailure {
    /// The frame fails with an error naming the worker and the phase.
    Abort,
    /// Workers lost at any phase (set-up, phase 1, collecting results,
    /// phase 2) have their cells (or bricks) split among the survivors,
    /// and the frame runs again on them (same image with `--canonical`
    /// and ERT off; within the ERT bound otherwise).
    Reassign,
}

pub use crate::cluster::remote::spawn::WorkerProgram;

/// Transport options of `pvrsim cluster`.
#[derive(Debug, Clone, Args)]
pub struct TransportArgs {
    /// Run the nodes on a real transport: `threads` (this process),
    /// `processes` (child processes on loopback TCP), `tcp` (workers
    /// started with `pvrsim worker`, see docs/running-across-machines.md)
    /// or `mpi` (under `mpirun -n N+1`; a build with `--features mpi`).
    /// Times are then wall-clock. Unset: the --clock setting (virtual by
    /// default).
    #[arg(long, value_enum)]
    pub transport: Option<TransportKind>,
    /// With --transport tcp: the workers, `host:port,host:port,...`, one
    /// per node, by rank.
    #[arg(long, value_delimiter = ',', value_name = "HOST:PORT,...")]
    pub workers: Vec<String>,
    /// With --transport tcp: a file of worker addresses, one `host:port`
    /// per line (`#` comments, blank lines ignored).
    #[arg(long, value_name = "FILE", conflicts_with = "workers")]
    pub hostfile: Option<PathBuf>,
    /// With --transport tcp: the shared token file (the workers' file).
    /// Without it only loopback workers can be used.
    #[arg(long, value_name = "FILE")]
    pub token_file: Option<PathBuf>,
    /// When a worker fails mid-frame: `abort` (an error naming the worker
    /// and the phase, non-zero exit) or `reassign` (workers lost at any
    /// phase: their cells or bricks go to the survivors and the frame runs
    /// again on them; `tcp` workers must then serve more than one frame,
    /// i.e. not `--once`). See docs/running-across-machines.md, "Failures".
    #[arg(long, value_enum, default_value_t = OnFailure::Abort)]
    pub on_failure: OnFailure,
    /// Seconds without a frame or heartbeat before a worker is declared
    /// lost (stalled or dead).
    #[arg(long, value_name = "SECONDS", default_value_t = 3.0)]
    pub heartbeat_timeout: f64,
    /// Seconds a rank may wait for its next message before the frame fails
    /// as a protocol deadlock.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0)]
    pub recv_timeout: f64,
    /// Test hook, with --transport processes: `RANK:ARGS` passes ARGS (the
    /// worker's hidden `--test-...` hooks, space-separated) to the child of
    /// rank RANK only, e.g. `2:--test-stop --test-kill-in-phase2`. Hidden.
    #[arg(long, value_name = "RANK:ARGS", hide = true)]
    pub test_worker_hook: Option<String>,
    /// The program that starts a worker process (`--transport processes`):
    /// this program unless a frontend names another (the Python module:
    /// its interpreter with `-m pvrsim`). Not a command-line option.
    #[arg(skip)]
    pub worker_program: Option<crate::cluster::remote::spawn::WorkerProgram>,
}

/// The error of `--transport mpi` in a build without the `mpi` feature.
pub const NO_MPI: &str = "--transport mpi: this pvrsim was built without MPI support. Install \
    OpenMPI (Debian: apt-get install libopenmpi-dev openmpi-bin libclang-dev) and build with \
    `cargo build --release --features mpi` (README.md, \"Running under MPI\")";

/// Reads a hostfile: one `host:port` per line.
pub fn read_hostfile(path: &Path) -> anyhow::Result<Vec<String>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read hostfile {}", path.display()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let l = line.split('#').next().unwrap_or("").trim();
        if l.is_empty() {
            continue;
        }
        anyhow::ensure!(
            !l.contains(char::is_whitespace)
                && l.rsplit_once(':')
                    .is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok()),
            "{}:{}: `{l}` is not host:port",
            path.display(),
            i + 1
        );
        out.push(l.to_string());
    }
    anyhow::ensure!(
        !out.is_empty(),
        "hostfile {} lists no workers",
        path.display()
    );
    Ok(out)
}

impl TransportArgs {
    /// Makes worker processes start as `argv` (the executable, then its
    /// leading arguments) followed by `worker ...`: how a frontend that is
    /// not a `pvrsim` binary (the Python module) names its program.
    pub fn set_worker_argv(&mut self, argv: Vec<std::ffi::OsString>) -> anyhow::Result<()> {
        self.worker_program = Some(WorkerProgram::new(argv)?);
        Ok(())
    }

    /// The program that starts worker processes: the one a frontend set
    /// ([`TransportArgs::worker_program`]), else this program.
    pub fn worker_program(&self) -> anyhow::Result<crate::cluster::remote::spawn::WorkerProgram> {
        match &self.worker_program {
            Some(p) => Ok(p.clone()),
            None => crate::cluster::remote::spawn::WorkerProgram::this(),
        }
    }

    /// Checks the combination of options and applies `threads` to `cfg`
    /// (the wall clock). Returns the kind if the run needs this module.
    pub fn apply(&self, cfg: &mut ClusterConfig) -> anyhow::Result<Option<TransportKind>> {
        let tcp_only =
            !self.workers.is_empty() || self.hostfile.is_some() || self.token_file.is_some();
        if tcp_only && self.transport != Some(TransportKind::Tcp) {
            anyhow::bail!("--workers, --hostfile and --token-file need --transport tcp");
        }
        anyhow::ensure!(
            self.heartbeat_timeout.is_finite() && self.heartbeat_timeout > 0.2,
            "--heartbeat-timeout must be more than 0.2 s (the heartbeat period)"
        );
        anyhow::ensure!(
            self.recv_timeout.is_finite() && self.recv_timeout > 0.0,
            "--recv-timeout must be a positive number of seconds"
        );
        self.worker_hook()?;
        if self.transport == Some(TransportKind::Mpi) {
            anyhow::ensure!(cfg!(feature = "mpi"), NO_MPI);
            anyhow::ensure!(
                self.on_failure == OnFailure::Abort,
                "--on-failure reassign is not available with --transport mpi: a rank that dies \
                 ends the whole MPI job (use --transport processes or tcp)"
            );
        }
        match self.transport {
            None => Ok(None),
            Some(TransportKind::Threads) => {
                cfg.phase1.clock = ClockKind::Wall;
                Ok(None)
            }
            Some(k) => {
                if cfg.baselines {
                    // The references would run here, not on the workers.
                    eprintln!(
                        "note: the sequential and Base references are not run with --transport {}; \
                         the report's ratios are null (pass --no-baselines to silence this)",
                        k.name()
                    );
                    cfg.baselines = false;
                }
                cfg.phase1.clock = ClockKind::Wall;
                Ok(Some(k))
            }
        }
    }

    /// `--test-worker-hook RANK:ARGS`, checked: the rank and the worker
    /// arguments (`--test-...` options and their numbers only), and only
    /// with `--transport processes`.
    pub fn worker_hook(&self) -> anyhow::Result<Option<(usize, Vec<String>)>> {
        let Some(h) = &self.test_worker_hook else {
            return Ok(None);
        };
        anyhow::ensure!(
            self.transport == Some(TransportKind::Processes),
            "--test-worker-hook needs --transport processes"
        );
        let bad = || anyhow::anyhow!("--test-worker-hook {h:?}: not RANK:--test-... hooks");
        let (rank, args) = h.split_once(':').ok_or_else(bad)?;
        let rank: usize = rank.trim().parse().map_err(|_| bad())?;
        let args: Vec<String> = args.split_whitespace().map(str::to_string).collect();
        let hookish = |a: &String| a.starts_with("--test-") || a.parse::<u64>().is_ok();
        anyhow::ensure!(!args.is_empty() && args.iter().all(hookish), bad());
        Ok(Some((rank, args)))
    }

    /// Link timing from these options: the heartbeat deadline, and a
    /// connect + handshake limit no longer than it (between 1 and 5 s), so
    /// that a stalled worker at set-up is noticed within the deadline too.
    pub fn tcp_options(&self) -> TcpOptions {
        let deadline = Duration::from_secs_f64(self.heartbeat_timeout);
        TcpOptions {
            deadline,
            handshake_timeout: deadline.clamp(Duration::from_secs(1), Duration::from_secs(5)),
            ..Default::default()
        }
    }
}
