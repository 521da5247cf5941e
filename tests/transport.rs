//! Real transports: the same frame on threads, worker processes and TCP
//! workers gives the same image bit for bit; failures (kill -9, SIGSTOP,
//! wrong token, garbage, forged length, malformed frame) end the frame with
//! an error naming the worker, within the deadline, with every child
//! reaped. Only 127.0.0.1 is used.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use clap::Parser;
use pvrsim::cli::{Cli, Command as Cmd};
use pvrsim::cluster::remote::{Coordinator, LocalWorkers};
use pvrsim::cluster::ClusterConfig;
use pvrsim::net::tcp::{self, Role, TcpOptions, Token};
use pvrsim::render::RenderInput;

const EXE: &str = env!("CARGO_BIN_EXE_pvrsim");

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The config and input of `pvrsim cluster SCENE ARGS...`.
fn config(scene: &Path, args: &[&str]) -> (RenderInput, ClusterConfig) {
    let mut v = vec![
        "pvrsim",
        "cluster",
        scene.to_str().unwrap(),
        "--no-baselines",
    ];
    v.extend_from_slice(args);
    let Cmd::Cluster(a) = Cli::try_parse_from(v).unwrap().command else {
        unreachable!()
    };
    let (input, _) = RenderInput::load(&a.scene).unwrap();
    let cfg = pvrsim::cli::cluster::config(&a).unwrap();
    (input, cfg)
}

fn bits(img: &pvrsim::image::Image) -> Vec<u32> {
    img.pixels
        .iter()
        .flat_map(|p| p.iter().map(|c| c.to_bits()))
        .collect()
}

/// A `pvrsim worker` child whose stderr lines are forwarded to a channel.
struct WorkerProc {
    child: Child,
    addr: String,
    lines: crossbeam_channel::Receiver<String>,
}

impl WorkerProc {
    fn start(token: Option<&Path>, extra: &[&str]) -> WorkerProc {
        Self::start_with(token, extra, true)
    }

    /// `once`: serve one session (`--once`), else serve until killed.
    fn start_with(token: Option<&Path>, extra: &[&str], once: bool) -> WorkerProc {
        let mut c = Command::new(EXE);
        c.args([
            "worker",
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

    fn wait_line(&self, needle: &str, within: Duration) -> bool {
        let until = Instant::now() + within;
        while let Ok(l) = self
            .lines
            .recv_timeout(until.saturating_duration_since(Instant::now()))
        {
            if l.contains(needle) {
                return true;
            }
        }
        false
    }

    fn signal(&self, sig: &str) {
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

fn token_file(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    Token::random().unwrap().save(&p).unwrap();
    p
}

/// Runs `pvrsim cluster` as a child with a hard deadline; returns
/// (success, stderr, seconds).
fn cluster_cli(args: &[&str], deadline: Duration) -> (bool, String, f64) {
    let t = Instant::now();
    let mut child = Command::new(EXE)
        .arg("cluster")
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
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

#[test]
fn same_image_on_threads_processes_and_tcp() {
    let scene = data("aorta-small-view-b.toml");
    for extra in [
        &["--nodes", "3", "--canonical", "--ert", "1"][..],
        &[
            "--nodes",
            "4",
            "--canonical",
            "--ert",
            "1",
            "--dlb",
            "--compositor",
            "direct-send",
        ][..],
    ] {
        let (input, cfg) = config(&scene, extra);
        let virt = pvrsim::cluster::run(&input, &cfg).unwrap();
        let mut wall = cfg.clone();
        wall.phase1.clock = pvrsim::cluster::ClockKind::Wall;
        let threads = pvrsim::cluster::run(&input, &wall).unwrap();
        assert_eq!(bits(&threads.image), bits(&virt.image), "{extra:?}");

        let n = cfg.phase1.nodes;
        let workers = LocalWorkers::spawn(Path::new(EXE), n, &[], Duration::from_secs(30)).unwrap();
        let (procs, m) = Coordinator {
            workers: workers.addrs.clone(),
            token: workers.token().clone(),
            tcp: TcpOptions::default(),
            recv_timeout: Duration::from_secs(60),
            reassign: false,
        }
        .run(&input, &cfg)
        .unwrap();
        assert_eq!(bits(&procs.image), bits(&virt.image), "{extra:?}");
        assert!(m.cells_bytes_sent > 0);
        drop(workers);

        // TCP workers started by hand, with a token file.
        let dir = tempfile::tempdir().unwrap();
        let tok = token_file(dir.path(), "token");
        let ws: Vec<WorkerProc> = (0..n).map(|_| WorkerProc::start(Some(&tok), &[])).collect();
        let (tcp_out, _) = Coordinator {
            workers: ws.iter().map(|w| w.addr.clone()).collect(),
            token: Token::load(&tok).unwrap(),
            tcp: TcpOptions::default(),
            recv_timeout: Duration::from_secs(60),
            reassign: false,
        }
        .run(&input, &cfg)
        .unwrap();
        assert_eq!(bits(&tcp_out.image), bits(&virt.image), "{extra:?}");
        assert_eq!(tcp_out.report.cells_processed, virt.report.cells_processed);
    }
}

/// The frame on `n` worker processes (loopback, fresh token).
fn on_processes(input: &RenderInput, cfg: &ClusterConfig) -> pvrsim::cluster::ClusterOutcome {
    let n = cfg.phase1.nodes;
    let workers = LocalWorkers::spawn(Path::new(EXE), n, &[], Duration::from_secs(30)).unwrap();
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
fn on_threads(input: &RenderInput, cfg: &ClusterConfig) -> pvrsim::cluster::ClusterOutcome {
    let mut wall = cfg.clone();
    wall.phase1.clock = pvrsim::cluster::ClockKind::Wall;
    pvrsim::cluster::run(input, &wall).unwrap()
}

/// Largest channel difference, in 1/255 units.
fn max_diff_255(a: &pvrsim::image::Image, b: &pvrsim::image::Image) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| p.iter().zip(q).map(|(x, y)| (x - y).abs() as f64))
        .fold(0.0, f64::max)
        * 255.0
}

/// ERT on, no sharing, no DLB: every node's schedule (its cells, its own
/// table, its update points) is fixed by the placement, so the image is the
/// same bit for bit on the virtual clock, threads, processes and TCP
/// workers (aorta-small view B at ERT 0.9 skips 3038 of 20169 cells on 3
/// nodes).
#[test]
fn same_image_with_ert_on_where_the_schedule_is_deterministic() {
    let scene = data("aorta-small-view-b.toml");
    let (input, cfg) = config(&scene, &["--nodes", "3", "--canonical", "--ert", "0.9"]);
    let virt = pvrsim::cluster::run(&input, &cfg).unwrap();
    assert!(
        virt.report.cells_skipped_ert > 0,
        "ERT must skip cells here, else the test shows nothing"
    );
    assert_eq!(bits(&on_threads(&input, &cfg).image), bits(&virt.image));
    assert_eq!(bits(&on_processes(&input, &cfg).image), bits(&virt.image));
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "token");
    let ws: Vec<WorkerProc> = (0..3).map(|_| WorkerProc::start(Some(&tok), &[])).collect();
    let (tcp_out, m) = Coordinator {
        workers: ws.iter().map(|w| w.addr.clone()).collect(),
        token: Token::load(&tok).unwrap(),
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(60),
        reassign: false,
    }
    .run(&input, &cfg)
    .unwrap();
    assert_eq!(bits(&tcp_out.image), bits(&virt.image));
    assert_eq!(
        tcp_out.report.cells_skipped_ert,
        virt.report.cells_skipped_ert
    );
    // Phase 2 ran worker to worker: the schedule's messages and bytes are
    // the in-process ones, and the transport counted the model's bytes
    // (plus headers and the root's hand-off, which the section takes off).
    assert_eq!(tcp_out.report.compositing, virt.report.compositing);
    let sec =
        pvrsim::cluster::remote::transport_section(&input, &cfg, &tcp_out, m.clone()).unwrap();
    assert!(sec.phase1_bytes_match, "{:?}", sec.phase1_by_kind);
    assert!(sec.phase2_bytes_match, "{:?}", sec.phase2_by_kind);
    let segs = &sec.phase2_by_kind["segments"];
    assert!(segs.measured.messages > 0 && segs.measured.bytes > segs.modelled.bytes);
    assert!(m.phase2_handoff_bytes > 0);
}

/// spx in cluster mode, ERT off, canonical: 1 and 8 virtual nodes and 5
/// worker processes give one image, bit for bit. The regression test of
/// `tests/data/spx.toml` in cluster mode: its cell 0 repeats a vertex, and
/// the work unit used to refuse it ("cell 0 has a bad vertex index").
#[test]
fn spx_renders_in_cluster_mode_with_any_node_count() {
    let scene = data("spx.toml");
    let (input, cfg1) = config(&scene, &["--nodes", "1", "--canonical", "--ert", "1"]);
    let one = pvrsim::cluster::run(&input, &cfg1).unwrap();
    assert!(
        one.image.pixels.iter().any(|p| p[3] > 0.1),
        "spx is not empty"
    );
    let (_, cfg8) = config(&scene, &["--nodes", "8", "--canonical", "--ert", "1"]);
    let eight = pvrsim::cluster::run(&input, &cfg8).unwrap();
    assert_eq!(bits(&eight.image), bits(&one.image));
    assert_eq!(eight.report.cells_processed, one.report.cells_processed);
    let (_, cfg5) = config(&scene, &["--nodes", "5", "--canonical", "--ert", "1"]);
    assert_eq!(bits(&on_processes(&input, &cfg5).image), bits(&one.image));
}

/// ERT on with sharing through the manager and DLB: which cells a node
/// skips depends on when the merged tables arrive, so the images of the
/// real transports may differ from the virtual one, but each stays within
/// the ERT bound `(1 - threshold) x max radiance` of the ERT-off image.
#[test]
fn ert_with_sharing_and_dlb_stays_within_the_bound_on_every_transport() {
    let scene = data("aorta-small-view-b.toml");
    let (input, off) = config(&scene, &["--nodes", "4", "--canonical", "--ert", "1"]);
    let full = pvrsim::cluster::run(&input, &off).unwrap();
    let (_, cfg) = config(
        &scene,
        &[
            "--nodes",
            "4",
            "--canonical",
            "--ert",
            "0.9",
            "--share",
            "--dlb",
        ],
    );
    let bound = pvrsim::render::cell::ert::error_bound(
        0.9,
        input.scene.transfer.max_radiance(),
        input.scene.image.background,
    ) * 255.0;
    for (name, out) in [
        ("virtual", pvrsim::cluster::run(&input, &cfg).unwrap()),
        ("threads", on_threads(&input, &cfg)),
        ("processes", on_processes(&input, &cfg)),
    ] {
        let d = max_diff_255(&out.image, &full.image);
        eprintln!("{name}: max-abs {d:.3}/255 vs ERT off (bound {bound:.3}/255)");
        assert!(d <= bound + 1e-3, "{name}: {d}/255 > bound {bound}/255");
    }
}

/// `--clock virtual` with a real transport is refused, not overridden.
#[test]
fn clock_virtual_with_a_transport_is_an_error() {
    let scene = data("spx.toml");
    for t in ["threads", "processes"] {
        let (ok, err, _) = cluster_cli(
            &[
                scene.to_str().unwrap(),
                "--transport",
                t,
                "--clock",
                "virtual",
                "-o",
                "/nonexistent-dir/x.png",
            ],
            Duration::from_secs(30),
        );
        assert!(!ok);
        assert!(
            err.contains("--clock virtual") && err.contains(&format!("--transport {t}")),
            "{err}"
        );
    }
}

/// `--on-failure reassign`: worker 1 kills itself (SIGKILL, the hidden
/// test hook) after 3 chunks of phase 1; its cells go to the two survivors,
/// the frame runs again on them and gives the undisturbed image bit for bit
/// (canonical, ERT off: the image does not depend on the placement). The
/// measured bytes equal the model's for the survivors' placement.
#[test]
fn reassign_after_kill_9_mid_frame_gives_the_same_image() {
    let scene = data("aorta-small-view-b.toml");
    let (input, cfg) = config(&scene, &["--nodes", "3", "--canonical", "--ert", "1"]);
    let virt = pvrsim::cluster::run(&input, &cfg).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "token");
    let ws: Vec<WorkerProc> = (0..3)
        .map(|k| {
            let hook: &[&str] = if k == 1 {
                &["--test-kill-after-chunks", "3"]
            } else {
                &[]
            };
            WorkerProc::start_with(Some(&tok), hook, false)
        })
        .collect();
    let c = Coordinator {
        workers: ws.iter().map(|w| w.addr.clone()).collect(),
        token: Token::load(&tok).unwrap(),
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(60),
        reassign: true,
    };
    let t = Instant::now();
    let (out, m) = c.run(&input, &cfg).unwrap();
    assert!(ws[1].wait_line("killing itself after 3 chunks", Duration::from_secs(5)));
    assert!(t.elapsed() < Duration::from_secs(40), "{:?}", t.elapsed());
    assert_eq!(bits(&out.image), bits(&virt.image));
    assert_eq!(out.report.n_nodes, 2);
    let r = m.reassigned.clone().expect("reassigned");
    assert_eq!(r.lost.len(), 1);
    assert!(r.lost[0].starts_with("worker 1 "), "{:?}", r.lost);
    assert!(r.cells > 0 && r.first_error.contains("worker 1"), "{r:?}");
    assert_eq!(
        r.parts.iter().map(Vec::len).sum::<usize>(),
        input.mesh.tets.len()
    );
    let sec = pvrsim::cluster::remote::transport_section(&input, &cfg, &out, m).unwrap();
    assert!(sec.phase1_bytes_match && sec.phase2_bytes_match);
    // Without reassign, the same failure is an error naming worker 1.
    let ws: Vec<WorkerProc> = (0..3)
        .map(|k| {
            let hook: &[&str] = if k == 1 {
                &["--test-kill-after-chunks", "3"]
            } else {
                &[]
            };
            WorkerProc::start(Some(&tok), hook)
        })
        .collect();
    let e = Coordinator {
        workers: ws.iter().map(|w| w.addr.clone()).collect(),
        reassign: false,
        ..c
    }
    .run(&input, &cfg)
    .unwrap_err();
    assert!(format!("{e:#}").contains("worker 1"), "{e:#}");
}

/// A worker killed (SIGKILL) when phase 2 starts: the frame fails with an
/// error naming it and phase 2, within the deadline, even with
/// `reassign` (which only covers phase 1).
#[test]
fn kill_9_in_phase_2_is_an_error_naming_the_worker_and_phase_2() {
    let (input, cfg) = config(
        &data("aorta-small-view-b.toml"),
        &["--nodes", "3", "--canonical", "--ert", "1"],
    );
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "token");
    let ws: Vec<WorkerProc> = (0..3)
        .map(|k| {
            let hook: &[&str] = if k == 2 {
                &["--test-kill-in-phase2"]
            } else {
                &[]
            };
            WorkerProc::start(Some(&tok), hook)
        })
        .collect();
    let t = Instant::now();
    let e = Coordinator {
        workers: ws.iter().map(|w| w.addr.clone()).collect(),
        token: Token::load(&tok).unwrap(),
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(60),
        reassign: true,
    }
    .run(&input, &cfg)
    .unwrap_err();
    let e = format!("{e:#}");
    assert!(e.contains("phase 2") && e.contains("worker 2"), "{e}");
    assert!(t.elapsed() < Duration::from_secs(30), "{:?}", t.elapsed());
    assert!(ws[2].wait_line("at the start of phase 2", Duration::from_secs(5)));
}

#[test]
fn a_worker_keeps_its_cells_between_sessions() {
    let (input, cfg) = config(
        &data("aorta-small-view-b.toml"),
        &["--nodes", "1", "--canonical"],
    );
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "token");
    // Not --once: serves two sessions.
    let mut child = Command::new(EXE)
        .args([
            "worker",
            "--listen",
            "127.0.0.1:0",
            "--accept-timeout",
            "60",
            "--token-file",
        ])
        .arg(&tok)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut addr = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut addr)
        .unwrap();
    let c = Coordinator {
        workers: vec![addr.trim().to_string()],
        token: Token::load(&tok).unwrap(),
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(60),
        reassign: false,
    };
    let (a, m1) = c.run(&input, &cfg).unwrap();
    let (b, m2) = c.run(&input, &cfg).unwrap();
    let _ = child.kill();
    let _ = child.wait();
    assert!(m1.cells_bytes_sent > 0 && m1.cells_cached == 0);
    assert_eq!((m2.cells_bytes_sent, m2.cells_cached), (0, 1));
    assert_eq!(bits(&a.image), bits(&b.image));
}

fn failure_run(sig: &str, hb: &str) -> (bool, String, f64) {
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "token");
    let ws: Vec<WorkerProc> = (0..2).map(|_| WorkerProc::start(Some(&tok), &[])).collect();
    let addrs = format!("{},{}", ws[0].addr, ws[1].addr);
    let scene = data("aorta-small-view-b.toml");
    let out = dir.path().join("o.png");
    let args: Vec<String> = [
        scene.to_str().unwrap(),
        "--nodes",
        "2",
        "--no-baselines",
        "--transport",
        "tcp",
        "--workers",
        &addrs,
        "--token-file",
        tok.to_str().unwrap(),
        "--heartbeat-timeout",
        hb,
        "-o",
        out.to_str().unwrap(),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let h = std::thread::spawn(move || {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        cluster_cli(&a, Duration::from_secs(60))
    });
    assert!(
        ws[0].wait_line("phase 1 started", Duration::from_secs(30)),
        "worker 0 never started phase 1"
    );
    ws[0].signal(sig);
    let r = h.join().unwrap();
    assert!(!out.exists(), "no image may be written after a failure");
    r
}

#[test]
fn kill_9_mid_frame_is_an_error_naming_the_worker() {
    let (ok, err, secs) = failure_run("-KILL", "3");
    assert!(!ok, "the frame must fail");
    assert!(err.contains("worker 0"), "{err}");
    assert!(
        err.contains("without Goodbye") || err.contains("connection"),
        "{err}"
    );
    assert!(secs < 30.0, "{secs} s");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn sigstop_mid_frame_hits_the_heartbeat_deadline() {
    let (ok, err, secs) = failure_run("-STOP", "1");
    assert!(!ok, "the frame must fail");
    assert!(err.contains("worker 0"), "{err}");
    assert!(err.contains("no heartbeat"), "{err}");
    assert!(secs < 30.0, "{secs} s");
}

#[test]
fn wrong_token_is_refused_with_the_worker_named() {
    let dir = tempfile::tempdir().unwrap();
    let (ta, tb) = (token_file(dir.path(), "a"), token_file(dir.path(), "b"));
    let w = WorkerProc::start(Some(&ta), &[]);
    let scene = data("aorta-small-view-b.toml");
    let (ok, err, _) = cluster_cli(
        &[
            scene.to_str().unwrap(),
            "--nodes",
            "1",
            "--no-baselines",
            "--transport",
            "tcp",
            "--workers",
            &w.addr,
            "--token-file",
            tb.to_str().unwrap(),
            "-o",
            dir.path().join("o.png").to_str().unwrap(),
        ],
        Duration::from_secs(30),
    );
    assert!(!ok);
    assert!(err.contains("worker 0") && err.contains("token"), "{err}");
    assert!(w.wait_line("refused a connection", Duration::from_secs(10)));
}

#[test]
fn garbage_on_the_port_does_not_stop_a_worker() {
    let (input, cfg) = config(&data("aorta-small-view-b.toml"), &["--nodes", "1"]);
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "token");
    let w = WorkerProc::start(Some(&tok), &[]);
    for junk in [&b"GET / HTTP/1.1\r\n\r\n"[..], &[0xff; 64][..], &[][..]] {
        let mut s = TcpStream::connect(&w.addr).unwrap();
        let _ = s.write_all(junk);
        drop(s);
    }
    assert!(w.wait_line("refused a connection", Duration::from_secs(10)));
    let (out, _) = Coordinator {
        workers: vec![w.addr.clone()],
        token: Token::load(&tok).unwrap(),
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(60),
        reassign: false,
    }
    .run(&input, &cfg)
    .unwrap();
    assert_eq!(out.report.n_nodes, 1);
}

#[test]
fn non_loopback_without_token_is_refused() {
    let out = Command::new(EXE)
        .args(["worker", "--listen", "0.0.0.0:0", "--once"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("without a token"), "{e}");
    assert!(out.stdout.is_empty(), "it must not print an address");
}

/// A fake worker that authenticates, then sends `bytes` on the link.
fn hostile_worker(bytes: Vec<u8>) -> (String, std::thread::JoinHandle<()>, Token) {
    let dir = tempfile::tempdir().unwrap();
    let tok_path = token_file(dir.path(), "t");
    let token = Token::load(&tok_path).unwrap();
    let rt = tcp::runtime().unwrap();
    let listener = rt
        .block_on(tokio::net::TcpListener::bind("127.0.0.1:0"))
        .unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let t2 = token.clone();
    let h = std::thread::spawn(move || {
        rt.block_on(async {
            use tokio::io::AsyncWriteExt;
            let (mut s, _, _) = tcp::accept(
                &listener,
                &t2,
                Role::Worker,
                u32::MAX,
                &TcpOptions::default(),
            )
            .await
            .unwrap();
            s.write_all(&bytes).await.unwrap();
            tokio::time::sleep(Duration::from_secs(2)).await;
        });
    });
    (addr, h, token)
}

fn hostile(bytes: Vec<u8>) -> String {
    let (input, cfg) = config(&data("aorta-small-view-b.toml"), &["--nodes", "1"]);
    let (addr, h, token) = hostile_worker(bytes);
    let t = Instant::now();
    let e = Coordinator {
        workers: vec![addr],
        token,
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(60),
        reassign: false,
    }
    .run(&input, &cfg)
    .unwrap_err();
    assert!(t.elapsed() < Duration::from_secs(20));
    h.join().unwrap();
    format!("{e:#}")
}

#[test]
fn forged_length_2_pow_60_is_an_error() {
    let mut b = vec![0u8]; // data frame
    b.extend_from_slice(&0u32.to_le_bytes());
    b.extend_from_slice(&1u32.to_le_bytes());
    b.push(6); // control
    b.extend_from_slice(&(1u64 << 60).to_le_bytes());
    let e = hostile(b);
    assert!(
        e.contains("worker 0") && e.contains("exceeds the limit"),
        "{e}"
    );
}

#[test]
fn malformed_frame_is_an_error() {
    let e = hostile(vec![9, 1, 2, 3]);
    assert!(
        e.contains("worker 0") && e.contains("unknown link frame tag 9"),
        "{e}"
    );
}

#[test]
fn garbage_instead_of_a_handshake_is_an_error() {
    let (input, cfg) = config(&data("aorta-small-view-b.toml"), &["--nodes", "1"]);
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap().to_string();
    let h = std::thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        let _ = s.write_all(&[0x5a; 200]);
        std::thread::sleep(Duration::from_millis(500));
    });
    let e = Coordinator {
        workers: vec![addr],
        token: Token::random().unwrap(),
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(30),
        reassign: false,
    }
    .run(&input, &cfg)
    .unwrap_err();
    h.join().unwrap();
    let e = format!("{e:#}");
    assert!(
        e.contains("worker 0") && e.contains("not a pvrsim peer"),
        "{e}"
    );
}
