//! `--transport processes`: `N` worker processes of this same binary on
//! loopback, with a fresh token in a private temporary folder. The guard
//! kills and reaps every child on every path out (error, panic unwinding,
//! normal end); each child also gives up by itself if no coordinator
//! connects within its accept timeout (the coordinator was killed before).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use anyhow::Context;

use crate::net::tcp::Token;

/// The program (and its leading arguments) that starts a worker process:
/// this program's own path on the command line; under the Python module
/// the interpreter with `-m pvrsim` (`current_exe()` is the interpreter
/// there: see `python/` and docs/python.md). Passed down explicitly from
/// the job's options (`TransportArgs::worker_program`), never a
/// process-wide setting.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WorkerProgram {
    argv: Vec<std::ffi::OsString>,
}

impl WorkerProgram {
    /// `argv[0]` started with `argv[1..]` before the worker's arguments.
    pub fn new(argv: Vec<std::ffi::OsString>) -> anyhow::Result<WorkerProgram> {
        anyhow::ensure!(!argv.is_empty(), "a worker program needs an executable");
        Ok(WorkerProgram { argv })
    }

    /// The executable `exe` alone (a `pvrsim` binary).
    pub fn exe(exe: &Path) -> WorkerProgram {
        WorkerProgram {
            argv: vec![exe.as_os_str().to_owned()],
        }
    }

    /// This program (when it is a `pvrsim` binary).
    pub fn this() -> anyhow::Result<WorkerProgram> {
        let exe = std::env::current_exe().context("cannot find this program's path")?;
        Ok(WorkerProgram::exe(&exe))
    }

    /// A command that starts it (the worker's arguments still to add).
    fn command(&self) -> Command {
        let mut c = Command::new(&self.argv[0]);
        c.args(&self.argv[1..]);
        c
    }
}

/// Running local workers. Dropping it kills and reaps them.
pub struct LocalWorkers {
    children: Vec<Child>,
    /// Their addresses, by rank.
    pub addrs: Vec<String>,
    /// They serve one session each (`--once`), then exit.
    pub once: bool,
    token: Token,
    dir: PathBuf,
}

impl LocalWorkers {
    /// Starts `n` workers: `PROGRAM worker --listen 127.0.0.1:0
    /// --token-file T --once --accept-timeout S` plus `extra` arguments, and
    /// reads each one's address from its first stdout line (within `wait`).
    pub fn spawn(
        program: &WorkerProgram,
        n: usize,
        extra: &[String],
        wait: Duration,
    ) -> anyhow::Result<Self> {
        Self::spawn_serving(program, n, extra, wait, true)
    }

    /// [`LocalWorkers::spawn`]; without `once`, the workers serve sessions
    /// until they are stopped (on drop) or their accept timeout passes.
    pub fn spawn_serving(
        program: &WorkerProgram,
        n: usize,
        extra: &[String],
        wait: Duration,
        once: bool,
    ) -> anyhow::Result<Self> {
        Self::spawn_hooked(program, n, extra, None, wait, once)
    }

    /// [`LocalWorkers::spawn_serving`], with `hook = Some((rank, args))`:
    /// `args` go to that rank's child only, after `extra` (the worker's
    /// hidden test hooks, from `pvrsim cluster --test-worker-hook`).
    pub fn spawn_hooked(
        program: &WorkerProgram,
        n: usize,
        extra: &[String],
        hook: Option<(usize, &[String])>,
        wait: Duration,
        once: bool,
    ) -> anyhow::Result<Self> {
        if let Some((rank, _)) = hook {
            anyhow::ensure!(
                rank < n,
                "--test-worker-hook: no worker {rank} among ranks 0..{}",
                n - 1
            );
        }
        let pid = std::process::id();
        let tag: String = crate::net::tcp::auth::random_bytes::<6>()?
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        let dir = std::env::temp_dir().join(format!("pvrsim-workers-{pid}-{tag}"));
        let mut b = std::fs::DirBuilder::new();
        #[cfg(unix)]
        {
            use std::os::unix::fs::DirBuilderExt;
            b.mode(0o700);
        }
        b.create(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        let token = Token::random()?;
        let token_path = dir.join("token");
        let mut me = LocalWorkers {
            children: Vec::with_capacity(n),
            addrs: Vec::with_capacity(n),
            once,
            token: token.clone(),
            dir,
        };
        token.save(&token_path)?;
        let accept_timeout = (wait.as_secs_f64() * 4.0).max(30.0);
        let (tx, rx) = crossbeam_channel::unbounded();
        for k in 0..n {
            let mut c = program
                .command()
                .arg("worker")
                // Their progress lines only when this process shows its own.
                .args(tracing::enabled!(tracing::Level::INFO).then_some("-v"))
                .args(["--listen", "127.0.0.1:0"])
                .args(once.then_some("--once"))
                .arg("--token-file")
                .arg(&token_path)
                .args(["--accept-timeout", &accept_timeout.to_string()])
                .args(extra)
                .args(hook.filter(|h| h.0 == k).map_or(&[][..], |h| h.1))
                .stdin(Stdio::null())
                .stdout(Stdio::piped())
                .stderr(Stdio::inherit())
                .spawn()
                .with_context(|| {
                    format!(
                        "cannot start worker {k} ({})",
                        program.argv[0].to_string_lossy()
                    )
                })?;
            let out = c.stdout.take();
            me.children.push(c);
            let tx = tx.clone();
            std::thread::spawn(move || {
                let mut line = String::new();
                let r = match out {
                    Some(o) => BufReader::new(o).read_line(&mut line).map(|_| line),
                    None => Ok(String::new()),
                };
                let _ = tx.send((k, r));
            });
        }
        let mut addrs = vec![String::new(); n];
        let until = std::time::Instant::now() + wait;
        for _ in 0..n {
            let left = until.saturating_duration_since(std::time::Instant::now());
            let (k, r) = rx.recv_timeout(left).map_err(|_| {
                anyhow::anyhow!("worker processes did not print their addresses within {wait:?}")
            })?;
            let line = r.with_context(|| format!("reading worker {k}'s address"))?;
            let a = line.trim();
            if a.is_empty() {
                let status = me.children[k].try_wait().ok().flatten();
                anyhow::bail!("worker process {k} exited before printing its address ({status:?})");
            }
            addrs[k] = a.to_string();
        }
        me.addrs = addrs;
        Ok(me)
    }

    /// The token the workers hold.
    pub fn token(&self) -> &Token {
        &self.token
    }

    /// The children's process ids, by rank.
    pub fn pids(&self) -> Vec<u32> {
        self.children.iter().map(Child::id).collect()
    }

    /// Waits (at most `wait`) for every child to exit; returns the ranks
    /// that exited with an error or had to be killed.
    pub fn finish(&mut self, wait: Duration) -> Vec<usize> {
        let until = std::time::Instant::now() + wait;
        let mut bad = Vec::new();
        for (k, c) in self.children.iter_mut().enumerate() {
            loop {
                match c.try_wait() {
                    Ok(Some(s)) => {
                        if !s.success() {
                            bad.push(k);
                        }
                        break;
                    }
                    Ok(None) if std::time::Instant::now() < until => {
                        std::thread::sleep(Duration::from_millis(20))
                    }
                    _ => {
                        let _ = c.kill();
                        let _ = c.wait();
                        bad.push(k);
                        break;
                    }
                }
            }
        }
        bad
    }
}

impl Drop for LocalWorkers {
    fn drop(&mut self) {
        for c in &mut self.children {
            if let Ok(None) = c.try_wait() {
                let _ = c.kill();
            }
            let _ = c.wait();
        }
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
