//! Helpers of the transport tests (`tests/transport.rs`,
//! `tests/transport_failures.rs`, `tests/faults*.rs`, ...): scene configs,
//! worker processes, the CLI with a deadline, runs on threads and on
//! worker processes, process trees (`procs.rs`).
#![allow(dead_code)]

mod procs;
#[allow(unused_imports)]
pub use procs::*;

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

use clap::Parser;
use pvrsim::cli::cluster::ClusterArgs;
use pvrsim::cli::{Cli, Command as Cmd};
use pvrsim::cluster::grid::GridConfig;
use pvrsim::cluster::remote::reassign::{LossEvent, Reassigned};
use pvrsim::cluster::remote::{Coordinator, LocalWorkers};
use pvrsim::cluster::ClusterConfig;
use pvrsim::net::tcp::{TcpOptions, Token};
use pvrsim::render::{RenderInput, VolumeInput};

pub const EXE: &str = env!("CARGO_BIN_EXE_pvrsim");

pub fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The arguments of `pvrsim cluster SCENE ARGS...`.
pub fn cluster_args(scene: &Path, args: &[&str]) -> Box<ClusterArgs> {
    let mut v = vec!["pvrsim", "cluster", scene.to_str().unwrap()];
    v.extend_from_slice(args);
    let Cmd::Cluster(a) = Cli::try_parse_from(v).unwrap().command else {
        unreachable!()
    };
    a
}

/// The config and input of `pvrsim cluster SCENE --no-baselines ARGS...`.
pub fn config(scene: &Path, args: &[&str]) -> (RenderInput, ClusterConfig) {
    let mut v = vec!["--no-baselines"];
    v.extend_from_slice(args);
    let a = cluster_args(scene, &v);
    let (input, _) = RenderInput::load(&a.scene).unwrap();
    let cfg = pvrsim::cli::cluster::config(&pvrsim::job::Valid::new(&*a).unwrap()).unwrap();
    (input, cfg)
}

pub fn bits(img: &pvrsim::image::Image) -> Vec<u32> {
    img.pixels
        .iter()
        .flat_map(|p| p.iter().map(|c| c.to_bits()))
        .collect()
}

/// A `pvrsim worker` child whose stderr lines are forwarded to a channel.
pub struct WorkerProc {
    pub child: Child,
    pub addr: String,
    pub lines: crossbeam_channel::Receiver<String>,
}

impl WorkerProc {
    pub fn start(token: Option<&Path>, extra: &[&str]) -> WorkerProc {
        Self::start_with(token, extra, true)
    }

    /// `once`: serve one session (`--once`), else serve until killed.
    pub fn start_with(token: Option<&Path>, extra: &[&str], once: bool) -> WorkerProc {
        let mut c = Command::new(EXE);
        c.args([
            "worker",
            // Progress lines ("a set-up from", "phase 1 started") that the
            // tests wait for.
            "-v",
            "--listen",
            "127.0.0.1:0",
            "--accept-timeout",
            "60",
        ]);
        if once {
            c.arg("--once");
        }
        if let Some(t) = token {
            c.arg("--token-file").arg(t);
        }
        let mut child = c
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut addr = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut addr)
            .unwrap();
        let (tx, rx) = crossbeam_channel::unbounded();
        let err = child.stderr.take().unwrap();
        std::thread::spawn(move || {
            for l in BufReader::new(err).lines().map_while(Result::ok) {
                let _ = tx.send(l);
            }
        });
        WorkerProc {
            child,
            addr: addr.trim().to_string(),
            lines: rx,
        }
    }

    pub fn wait_line(&self, needle: &str, within: Duration) -> bool {
        self.wait_line_or_seen(needle, within).is_ok()
    }

    /// As [`Self::wait_line`], with the lines read meanwhile when `needle`
    /// did not come (for the failure message).
    pub fn wait_line_or_seen(&self, needle: &str, within: Duration) -> Result<(), Vec<String>> {
        let until = Instant::now() + within;
        let mut seen = Vec::new();
        while let Ok(l) = self
            .lines
            .recv_timeout(until.saturating_duration_since(Instant::now()))
        {
            if l.contains(needle) {
                return Ok(());
            }
            seen.push(l);
        }
        Err(seen)
    }

    pub fn signal(&self, sig: &str) {
        let ok = Command::new("kill")
            .args([sig, &self.child.id().to_string()])
            .status()
            .unwrap()
            .success();
        assert!(ok, "kill {sig} failed");
    }
}

impl Drop for WorkerProc {
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .args(["-CONT", &self.child.id().to_string()])
            .status();
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub fn token_file(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    Token::random().unwrap().save(&p).unwrap();
    p
}

/// `pvrsim cluster ARGS` started as a child, stdout discarded, stderr
/// piped.
pub fn cluster_child(args: &[&str]) -> Child {
    Command::new(EXE)
        .arg("cluster")
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Asserts that `re` records one loss: worker `who` (a name prefix, e.g.
/// `"worker 2 "`) alone, in `phase`, some work moved to 3 survivors.
/// Returns the event.
pub fn assert_one_loss<'a>(
    case: &str,
    re: &'a Reassigned,
    phase: &str,
    who: &str,
) -> &'a LossEvent {
    assert_eq!(re.events.len(), 1, "{case}: {re:?}");
    let ev = &re.events[0];
    assert_eq!(ev.phase, phase, "{case}: {ev:?}");
    assert!(
        ev.workers.len() == 1 && ev.workers[0].starts_with(who),
        "{case}: {ev:?}"
    );
    assert!(ev.moved > 0 && ev.survivors == 3, "{case}: {ev:?}");
    ev
}

/// Runs `pvrsim cluster` as a child with a hard deadline; returns
/// (success, stderr, seconds).
pub fn cluster_cli(args: &[&str], deadline: Duration) -> (bool, String, f64) {
    let t = Instant::now();
    let mut child = cluster_child(args);
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            let s = reader.join().unwrap();
            return (st.success(), s, t.elapsed().as_secs_f64());
        }
        if t.elapsed() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("pvrsim cluster {args:?} hung past {deadline:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The frame on `n` worker processes (loopback, fresh token).
pub fn on_processes(input: &RenderInput, cfg: &ClusterConfig) -> pvrsim::cluster::ClusterOutcome {
    let n = cfg.phase1.nodes;
    let workers = LocalWorkers::spawn(
        &pvrsim::cluster::remote::spawn::WorkerProgram::exe(Path::new(EXE)),
        n,
        &[],
        Duration::from_secs(30),
    )
    .unwrap();
    Coordinator {
        workers: workers.addrs.clone(),
        token: workers.token().clone(),
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(60),
        reassign: false,
    }
    .run(input, cfg)
    .unwrap()
    .0
}

/// The same frame on the wall-clock threads.
pub fn on_threads(input: &RenderInput, cfg: &ClusterConfig) -> pvrsim::cluster::ClusterOutcome {
    let mut wall = cfg.clone();
    wall.phase1.clock = pvrsim::cluster::ClockKind::Wall;
    pvrsim::cluster::run(input, &wall).unwrap()
}

/// The volume input and grid config of `pvrsim cluster SCENE ARGS...`
/// for a grid scene.
pub fn grid_config(scene: &Path, args: &[&str]) -> (VolumeInput, GridConfig) {
    let a = cluster_args(scene, args);
    let cfg = pvrsim::cli::cluster_grid::config(&pvrsim::job::Valid::new(&*a).unwrap()).unwrap();
    let sc = pvrsim::scene::Scene::load(&a.scene).unwrap();
    let vol = pvrsim::data::io::read_volume(&sc.data.path, &sc.data.field).unwrap();
    (VolumeInput::new(sc, Arc::new(vol)).unwrap(), cfg)
}

/// A perspective scene of the bundled MNI crop (`tests/data/volume`) at
/// `size` = (width, height), written to `dir/crop.toml`.
pub fn grid_scene(dir: &Path, size: (u32, u32)) -> PathBuf {
    grid_scene_from(dir, "[60, -50, 70]", size)
}

/// [`grid_scene`] seen from `eye` (a TOML array), written to
/// `dir/crop-<len of eye>.toml` unless it is the default eye.
pub fn grid_scene_from(dir: &Path, eye: &str, size: (u32, u32)) -> PathBuf {
    let p = if eye == "[60, -50, 70]" {
        dir.join("crop.toml")
    } else {
        dir.join(format!("crop-{}.toml", eye.len()))
    };
    let vol = data("volume/mni-crop.nhdr");
    std::fs::write(
        &p,
        format!(
            r#"[data]
path = {:?}
field = "intensity"
[camera]
eye = {eye}
target = [-2.5, -18.5, 23.5]
up = [0, 0, 1]
projection = "perspective"
fov_y_deg = 40
[image]
width = {}
height = {}
background = [0.1, 0.1, 0.2]
[transfer]
unit_distance = 1
points = [[0, 0, 0, 0, 0], [0.3, 0.9, 0.6, 0.3, 0.05], [1, 1, 1, 0.9, 0.4]]
"#,
            vol.to_str().unwrap(),
            size.0,
            size.1
        ),
    )
    .unwrap();
    p
}

/// The heartbeat deadline of the fault tests' workers and coordinators.
pub const HB: std::time::Duration = std::time::Duration::from_secs(1);

/// TCP options with [`HB`] as both the heartbeat deadline and the
/// handshake timeout.
pub fn tcp_opts() -> pvrsim::net::tcp::TcpOptions {
    pvrsim::net::tcp::TcpOptions {
        deadline: HB,
        handshake_timeout: HB,
        ..Default::default()
    }
}
