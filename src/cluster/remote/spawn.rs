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

/// The program (and its first arguments) that starts a worker process in
/// place of the `exe` callers pass, when an embedding sets one: under the
/// Python module `current_exe()` is the Python interpreter, so the module
/// sets `[python, -m, pvrsim]` (see `python/` and docs/python.md). Unset
/// (the command line): `exe` itself.
static WORKER_PROGRAM: std::sync::OnceLock<Vec<std::ffi::OsString>> = std::sync::OnceLock::new();

/// Sets the worker program once per process (later calls are ignored); the
/// first element is the executable, the rest its leading arguments.
pub fn set_worker_program(argv: Vec<std::ffi::OsString>) {
    if !argv.is_empty() {
        let _ = WORKER_PROGRAM.set(argv);
    }
}

/// `exe`, or the program an embedding set ([`set_worker_program`]).
fn worker_command(exe: &Path) -> Command {
    match WORKER_PROGRAM.get() {
        Some(argv) => {
            let mut c = Command::new(&argv[0]);
            c.args(&argv[1..]);
            c
        }
        None => Command::new(exe),
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
    /// Starts `n` workers: `exe worker --listen 127.0.0.1:0 --token-file T
    /// --once --accept-timeout S` plus `extra` arguments, and reads each one's
    /// address from its first stdout line (within `wait`).
    pub fn spawn(exe: &Path, n: usize, extra: &[String], wait: Duration) -> anyhow::Result<Self> {
        Self::spawn_serving(exe, n, extra, wait, true)
    }

    /// [`LocalWorkers::spawn`]; without `once`, the workers serve sessions
    /// until they are stopped (on drop) or their accept timeout passes.
    pub fn spawn_serving(
        exe: &Path,
        n: usize,
        extra: &[String],
        wait: Duration,
        once: bool,
    ) -> anyhow::Result<Self> {
        Self::spawn_hooked(exe, n, extra, None, wait, once)
    }

    /// [`LocalWorkers::spawn_serving`], with `hook = Some((rank, args))`:
    /// `args` go to that rank's child only, after `extra` (the worker's
    /// hidden test hooks, from `pvrsim cluster --test-worker-hook`).
    pub fn spawn_hooked(
        exe: &Path,
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
            let mut c = worker_command(exe)
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
                .with_context(|| format!("cannot start worker {k} ({})", exe.display()))?;
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
