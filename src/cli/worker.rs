//! `pvrsim worker`: one worker process serving cluster frames over TCP.

use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

use clap::Args;

use crate::cluster::remote::Worker;
use crate::net::tcp::{TcpOptions, Token};

/// Options of `pvrsim worker`.
#[derive(Debug, Clone, Args)]
pub struct WorkerArgs {
    /// Address to listen on; port 0 picks a free port. The address is
    /// printed as the first line on stdout. A non-loopback address needs
    /// --token-file.
    #[arg(long, default_value = "127.0.0.1:0")]
    pub listen: String,
    /// The shared token (at least 32 random bytes; the same file as the
    /// coordinator's). Without it: loopback only.
    #[arg(long, value_name = "FILE")]
    pub token_file: Option<PathBuf>,
    /// Serve one session, then exit (status: that session's outcome).
    #[arg(long)]
    pub once: bool,
    /// Declare a peer lost after this many seconds without a frame or a
    /// heartbeat (heartbeats go every 200 ms on idle links).
    #[arg(long, value_name = "SECONDS", default_value_t = 3.0)]
    pub heartbeat_timeout: f64,
    /// Exit with an error if no coordinator starts a session within this
    /// many seconds (`--transport processes` sets it so orphans end).
    #[arg(long, value_name = "SECONDS")]
    pub accept_timeout: Option<f64>,
    /// Test hook: SIGKILL this process when its node starts chunk K+1 of
    /// phase 1 (a deterministic `kill -9` mid-frame). Hidden.
    #[arg(long, value_name = "K", hide = true)]
    pub test_kill_after_chunks: Option<u64>,
    /// Test hook: SIGKILL this process when phase 2 starts. Hidden.
    #[arg(long, hide = true)]
    pub test_kill_in_phase2: bool,
    /// Test hook: SIGKILL this process once a set-up has arrived, before
    /// the links to the peers are up. Hidden.
    #[arg(long, hide = true)]
    pub test_kill_at_setup: bool,
    /// Test hook: SIGKILL this process when phase 1 of frame F (from 1)
    /// of a session starts (a loss in the middle of a series). Hidden.
    #[arg(long, value_name = "F", hide = true)]
    pub test_kill_at_frame: Option<u64>,
    /// Test hook: the hooks above stop the process with SIGSTOP instead
    /// of killing it (once; it runs on when sent SIGCONT). Hidden.
    #[arg(long, hide = true)]
    pub test_stop: bool,
}

/// Runs `pvrsim worker`.
pub fn run(a: WorkerArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        a.heartbeat_timeout.is_finite() && a.heartbeat_timeout > 0.2,
        "--heartbeat-timeout must be more than 0.2 s (the heartbeat period)"
    );
    let accept = match a.accept_timeout {
        Some(s) if !(s.is_finite() && s > 0.0) => {
            anyhow::bail!("--accept-timeout must be a positive number of seconds")
        }
        Some(s) => Some(Duration::from_secs_f64(s)),
        None => None,
    };
    let token = match &a.token_file {
        Some(p) => Token::load(p)?,
        None => Token::none(),
    };
    let opts = TcpOptions {
        deadline: Duration::from_secs_f64(a.heartbeat_timeout),
        ..Default::default()
    };
    let mut w = Worker::bind(&a.listen, token, opts)?;
    w.accept_timeout = accept;
    w.kill_after_chunks = a.test_kill_after_chunks;
    w.kill_in_phase2 = a.test_kill_in_phase2;
    w.kill_at_setup = a.test_kill_at_setup;
    anyhow::ensure!(
        a.test_kill_at_frame != Some(0),
        "--test-kill-at-frame counts frames from 1"
    );
    w.kill_at_frame = a.test_kill_at_frame;
    if a.test_stop {
        crate::cluster::remote::worker::hooks_stop_instead();
    }
    let mut out = std::io::stdout().lock();
    writeln!(out, "{}", w.local_addr()?)?;
    out.flush()?;
    drop(out);
    w.serve(a.once)
}
