//! Process trees for the `--transport processes` fault tests: the
//! children of a process (from `/proc`), a child stopped by a test hook,
//! and `pvrsim cluster` run with its stderr lines timed and its children
//! recorded.

use std::collections::BTreeSet;
use std::io::{BufRead, BufReader};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The children of `parent` with their state (`R`, `S`, `T` stopped, `Z`
/// zombie, ...), from `/proc/*/stat`.
pub fn children_of(parent: u32) -> Vec<(u32, char)> {
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    dir.filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
        .filter_map(|pid| {
            let (state, ppid) = stat(pid)?;
            (ppid == parent).then_some((pid, state))
        })
        .collect()
}

/// The state and parent of `pid` (`None`: no such process).
pub fn stat(pid: u32) -> Option<(char, u32)> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // `pid (comm) state ppid ...`: comm may hold spaces and parentheses.
    let rest = &s[s.rfind(')')? + 1..];
    let mut f = rest.split_whitespace();
    let state = f.next()?.chars().next()?;
    let ppid = f.next()?.parse().ok()?;
    Some((state, ppid))
}

/// The command line of `pid`, arguments joined by spaces.
pub fn cmdline(pid: u32) -> String {
    std::fs::read(format!("/proc/{pid}/cmdline"))
        .map(|b| String::from_utf8_lossy(&b).replace('\0', " "))
        .unwrap_or_default()
}

/// Waits, until `done` is set, for a child of `parent` stopped (state
/// `T`) whose command line holds `needle`; its pid.
pub fn stopped_child(parent: u32, needle: &str, done: &AtomicBool) -> Option<u32> {
    while !done.load(Ordering::SeqCst) {
        let hit = children_of(parent)
            .into_iter()
            .find(|&(pid, st)| st == 'T' && cmdline(pid).contains(needle));
        if let Some((pid, _)) = hit {
            return Some(pid);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    None
}

/// Whether a TCP socket of `pid` is in `CLOSE_WAIT`: its peer closed the
/// connection, and `pid` has not (a stopped process cannot; the kernel
/// still takes the FIN). From `/proc/PID/fd` and `/proc/net/tcp{,6}`.
pub fn peer_closed_on(pid: u32) -> bool {
    let Ok(fds) = std::fs::read_dir(format!("/proc/{pid}/fd")) else {
        return false;
    };
    let inodes: BTreeSet<String> = fds
        .filter_map(|e| {
            let l = std::fs::read_link(e.ok()?.path()).ok()?;
            let l = l.to_str()?;
            Some(l.strip_prefix("socket:[")?.strip_suffix(']')?.to_string())
        })
        .collect();
    ["/proc/net/tcp", "/proc/net/tcp6"].iter().any(|t| {
        std::fs::read_to_string(t).is_ok_and(|s| {
            s.lines().skip(1).any(|l| {
                let f: Vec<&str> = l.split_whitespace().collect();
                // sl local remote st ... uid timeout inode
                f.len() > 9 && f[3] == "08" && inodes.contains(f[9])
            })
        })
    })
}

/// A finished `pvrsim cluster` child.
pub struct CliRun {
    /// Exit status 0.
    pub ok: bool,
    /// Its stderr (and its worker children's, which inherit it), each line
    /// with the time it was read, from the start.
    pub lines: Vec<(Duration, String)>,
    /// When it exited, from the start.
    pub end: Duration,
    /// Every child process seen while it ran (polled: a short-lived one
    /// may be missed).
    pub children: BTreeSet<u32>,
    /// Its pid.
    pub pid: u32,
}

impl CliRun {
    /// Its stderr.
    pub fn stderr(&self) -> String {
        let v: Vec<&str> = self.lines.iter().map(|(_, l)| l.as_str()).collect();
        v.join("\n")
    }

    /// When the first line holding `needle` was read.
    pub fn line_at(&self, needle: &str) -> Option<Duration> {
        self.lines
            .iter()
            .find(|(_, l)| l.contains(needle))
            .map(|(t, _)| *t)
    }

    /// Its worker children that still exist after `grace` (not reaped;
    /// or orphaned, running or stopped): those seen while it ran, and any
    /// process holding its `--transport processes` token folder
    /// (`pvrsim-workers-PID-...`, see `src/cluster/remote/spawn.rs`).
    pub fn children_left(&self, grace: Duration) -> Vec<(u32, char)> {
        let tag = format!("pvrsim-workers-{}-", self.pid);
        let until = Instant::now() + grace;
        loop {
            let mut pids = self.children.clone();
            if let Ok(dir) = std::fs::read_dir("/proc") {
                pids.extend(
                    dir.filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
                        .filter(|&p| cmdline(p).contains(&tag)),
                );
            }
            let left: Vec<(u32, char)> = pids
                .into_iter()
                .filter_map(|p| stat(p).map(|(st, _)| (p, st)))
                .filter(|&(_, st)| st != 'Z')
                .collect();
            if left.is_empty() || Instant::now() >= until {
                return left;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// Runs `pvrsim cluster ARGS` with a hard deadline (a panic past it: a
/// hang), recording its stderr lines as they come and its children.
pub fn cluster_cli_watched(args: &[&str], deadline: Duration) -> CliRun {
    let t = Instant::now();
    let mut child = super::cluster_child(args);
    let err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        BufReader::new(err)
            .lines()
            .map_while(Result::ok)
            .map(|l| (t.elapsed(), l))
            .collect::<Vec<_>>()
    });
    let mut children = BTreeSet::new();
    loop {
        children.extend(children_of(child.id()).into_iter().map(|(p, _)| p));
        if let Some(st) = child.try_wait().unwrap() {
            let end = t.elapsed();
            // The workers' copies of stderr close as they end.
            let lines = reader.join().unwrap();
            return CliRun {
                ok: st.success(),
                lines,
                end,
                children,
                pid: child.id(),
            };
        }
        if t.elapsed() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("pvrsim cluster {args:?} hung past {deadline:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}
