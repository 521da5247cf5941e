//! Real transports, failures: kill -9 and SIGSTOP mid-frame, a death in
//! phase 2, a wrong token, garbage, a forged length, a malformed frame, a
//! non-loopback address without a token, `--clock virtual` with a
//! transport: each ends with an error naming the worker and the phase,
//! within the deadline, with every child reaped. Only 127.0.0.1 is used.

use std::io::Write;
use std::net::TcpStream;
use std::process::Command;
use std::time::{Duration, Instant};

use pvrsim::cluster::remote::Coordinator;
use pvrsim::net::tcp::{self, Role, TcpOptions, Token};

mod transport_support;
use transport_support::*;

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

/// One frame of aorta-small view B (3 nodes, canonical, ERT off) over 3 TCP
/// workers, worker `victim` started with the test hook `hook`; the frame
/// must fail. Returns the error, the workers and how long the frame took.
fn hooked_frame(victim: usize, hook: &str, reassign: bool) -> (String, Vec<WorkerProc>, Duration) {
    let (input, cfg) = config(
        &data("aorta-small-view-b.toml"),
        &["--nodes", "3", "--canonical", "--ert", "1"],
    );
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "token");
    let ws: Vec<WorkerProc> = (0..3)
        .map(|k| {
            let hooks: &[&str] = if k == victim { &[hook] } else { &[] };
            WorkerProc::start(Some(&tok), hooks)
        })
        .collect();
    let t = Instant::now();
    let e = Coordinator {
        workers: ws.iter().map(|w| w.addr.clone()).collect(),
        token: Token::load(&tok).unwrap(),
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(60),
        reassign,
    }
    .run(&input, &cfg)
    .unwrap_err();
    (format!("{e:#}"), ws, t.elapsed())
}

/// A worker killed (SIGKILL) when phase 2 starts: without `reassign` the
/// frame fails with an error naming it and phase 2, within the deadline
/// (`tests/faults.rs` covers `reassign` at every phase).
#[test]
fn kill_9_in_phase_2_is_an_error_naming_the_worker_and_phase_2() {
    let (e, ws, took) = hooked_frame(2, "--test-kill-in-phase2", false);
    assert!(e.contains("phase 2") && e.contains("worker 2"), "{e}");
    assert!(took < Duration::from_secs(30), "{took:?}");
    assert!(ws[2].wait_line("at the start of phase 2", Duration::from_secs(5)));
}

/// A worker killed (SIGKILL) at set-up, before the links between the
/// workers are up: the error names that worker, not a survivor that said
/// Goodbye when the mesh could not form (issue 26).
#[test]
fn kill_9_at_set_up_names_the_worker_that_died() {
    let (e, ws, took) = hooked_frame(1, "--test-kill-at-setup", false);
    assert!(ws[1].wait_line("at set-up", Duration::from_secs(5)), "{e}");
    assert!(e.contains("worker 1"), "{e}");
    assert!(
        !e.contains("worker 0") && !e.contains("worker 2"),
        "names a survivor: {e}"
    );
    assert!(took < Duration::from_secs(30), "{took:?}");
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
