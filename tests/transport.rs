//! Real transports: the same frame on threads, worker processes and TCP
//! workers gives the same image bit for bit (ERT off, and ERT on where the
//! schedule is deterministic; within the ERT bound otherwise); phase 2 runs
//! worker to worker with the model's bytes; `--on-failure reassign`; the
//! worker's cell cache. Only 127.0.0.1 is used. Failures:
//! `tests/transport_failures.rs`.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use pvrsim::cluster::remote::spawn::WorkerProgram;
use pvrsim::cluster::remote::{Coordinator, LocalWorkers};
use pvrsim::net::tcp::{TcpOptions, Token};

mod transport_support;
use transport_support::*;

/// Worker options for a test that checks images, not stall detection: a
/// 30 s heartbeat deadline, so that a loaded machine (CPU starvation of
/// seconds) does not make a worker declare a live peer dead.
fn slow_ok() -> Vec<String> {
    vec!["--heartbeat-timeout".into(), "30".into()]
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
        let workers = LocalWorkers::spawn(
            &WorkerProgram::exe(Path::new(EXE)),
            n,
            &slow_ok(),
            Duration::from_secs(30),
        )
        .unwrap();
        let (procs, m) = Coordinator {
            workers: workers.addrs.clone(),
            token: workers.token().clone(),
            tcp: TcpOptions {
                deadline: Duration::from_secs(30),
                ..Default::default()
            },
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
        let ws: Vec<WorkerProc> = (0..n)
            .map(|_| WorkerProc::start(Some(&tok), &["--heartbeat-timeout", "30"]))
            .collect();
        let (tcp_out, _) = Coordinator {
            workers: ws.iter().map(|w| w.addr.clone()).collect(),
            token: Token::load(&tok).unwrap(),
            tcp: TcpOptions {
                deadline: Duration::from_secs(30),
                ..Default::default()
            },
            recv_timeout: Duration::from_secs(60),
            reassign: false,
        }
        .run(&input, &cfg)
        .unwrap();
        assert_eq!(bits(&tcp_out.image), bits(&virt.image), "{extra:?}");
        assert_eq!(tcp_out.report.cells_processed, virt.report.cells_processed);
    }
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
        let d = out.image.error_against_rgba(&full.image).max_abs;
        eprintln!("{name}: max-abs {d:.3}/255 vs ERT off (bound {bound:.3}/255)");
        assert!(d <= bound + 1e-3, "{name}: {d}/255 > bound {bound}/255");
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

/// Without the `mpi` feature, `--transport mpi` fails at once with an
/// error that says how to build with it (the MPI frame itself is checked
/// by `scripts/mpi-check.sh`, which builds `--features mpi`).
#[cfg(not(feature = "mpi"))]
#[test]
fn transport_mpi_without_the_feature_says_how_to_build_it() {
    let scene = data("aorta-small-view-b.toml");
    let out = tempfile::tempdir().unwrap();
    let png = out.path().join("x.png");
    let (ok, err, _) = cluster_cli(
        &[
            scene.to_str().unwrap(),
            "--nodes",
            "2",
            "--transport",
            "mpi",
            "-o",
            png.to_str().unwrap(),
        ],
        Duration::from_secs(60),
    );
    assert!(!ok, "{err}");
    assert!(
        err.contains("built without MPI") && err.contains("--features mpi"),
        "{err}"
    );
    assert!(!png.exists());
}
