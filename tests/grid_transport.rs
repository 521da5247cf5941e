//! Grid scenes over real transports: the same frame of `--nodes 4
//! --subvolumes 2 --master` on the virtual clock, on threads and on worker
//! processes gives the same image bit for bit; workers keep their bricks
//! (content hash) and a second frame with another view sends none; refused
//! combinations name the option. Data: the 32^3 crop of mni152 in
//! tests/data/volume (see tests/data/README.md). Only 127.0.0.1 is used.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use clap::Parser;
use pvrsim::cli::{Cli, Command as Cmd};
use pvrsim::cluster::grid::{run, GridConfig};
use pvrsim::cluster::remote::grid::GridRemote;
use pvrsim::cluster::remote::spawn::WorkerProgram;
use pvrsim::cluster::remote::LocalWorkers;
use pvrsim::cluster::ClockKind;
use pvrsim::net::tcp::TcpOptions;
use pvrsim::render::VolumeInput;

mod transport_support;
use transport_support::{bits, grid_scene_from, EXE};

fn scene(dir: &Path, eye: &str) -> std::path::PathBuf {
    grid_scene_from(dir, eye, (48, 40))
}

fn config(scene: &Path, args: &[&str]) -> anyhow::Result<(VolumeInput, GridConfig)> {
    let mut v = vec!["pvrsim", "cluster", scene.to_str().unwrap()];
    v.extend_from_slice(args);
    let Cmd::Cluster(a) = Cli::try_parse_from(v).unwrap().command else {
        unreachable!()
    };
    let cfg = pvrsim::cli::cluster_grid::config(&pvrsim::job::Valid::new(&*a)?)?;
    let sc = pvrsim::scene::Scene::load(&a.scene).unwrap();
    let vol = pvrsim::data::io::read_volume(&sc.data.path, &sc.data.field).unwrap();
    Ok((VolumeInput::new(sc, Arc::new(vol)).unwrap(), cfg))
}

fn remote(w: &LocalWorkers) -> GridRemote {
    GridRemote {
        workers: w.addrs.clone(),
        token: w.token().clone(),
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(60),
        transport: "processes".into(),
        reassign: false,
    }
}

#[test]
fn same_grid_image_on_the_virtual_clock_threads_and_processes() {
    let dir = tempfile::tempdir().unwrap();
    let s1 = scene(dir.path(), "[60, -50, 70]");
    let s2 = scene(dir.path(), "[-40, -70, 50.5]");
    let args = ["--nodes", "4", "--subvolumes", "2", "--master"];
    let workers = LocalWorkers::spawn_serving(
        &WorkerProgram::exe(Path::new(EXE)),
        4,
        &[],
        Duration::from_secs(30),
        false,
    )
    .unwrap();
    for (k, s) in [&s1, &s2].into_iter().enumerate() {
        for extra in [&[][..], &["--codec", "rle-paper", "--blocks", "2"][..]] {
            let mut a = args.to_vec();
            a.extend_from_slice(extra);
            let (input, cfg) = config(s, &a).unwrap();
            assert_eq!(cfg.clock, ClockKind::Virtual);
            let virt = run(&input, &cfg).unwrap();
            assert!(
                virt.image.pixels.iter().any(|p| p[3] > 0.2),
                "a visible frame"
            );
            let mut wall = cfg.clone();
            wall.clock = ClockKind::Wall;
            let threads = run(&input, &wall).unwrap();
            assert_eq!(bits(&threads.image), bits(&virt.image), "threads {extra:?}");
            let (procs, m) = remote(&workers).run(&input, &cfg).unwrap();
            assert_eq!(bits(&procs.image), bits(&virt.image), "processes {extra:?}");
            // The subimages crossed the transport with the model's bytes.
            let to_master = &virt.report.rounds[0];
            assert_eq!(to_master.0, "to master");
            assert_eq!(m.layer_bytes, to_master.2, "{extra:?}");
            assert_eq!(procs.report.bytes_total, virt.report.bytes_total);
            assert_eq!(procs.report.size_ratio, virt.report.size_ratio);
            // Bricks go once: the second view finds them in the cache.
            if k == 0 && extra.is_empty() {
                assert_eq!(m.bricks_cached, 0);
                assert!(m.bricks_bytes_sent >= 32 * 32 * 32);
            } else {
                assert_eq!(
                    (m.bricks_cached, m.bricks_bytes_sent),
                    (4, 0),
                    "{k} {extra:?}"
                );
            }
        }
    }
}

/// Without a master the workers composite among themselves (binary swap,
/// direct send, radix-k, master at worker 0): the image of threads bit for
/// bit, the same bytes in every round; a second frame reuses the workers'
/// bricks and textures and gives the threads' second frame.
#[test]
fn grid_workers_composite_worker_to_worker_as_threads_do() {
    let dir = tempfile::tempdir().unwrap();
    let s1 = scene(dir.path(), "[60, -50, 70]");
    let s2 = scene(dir.path(), "[-40, -70, 50.5]");
    let workers = LocalWorkers::spawn_serving(
        &WorkerProgram::exe(Path::new(EXE)),
        4,
        &[],
        Duration::from_secs(30),
        false,
    )
    .unwrap();
    for comp in ["binary-swap", "direct-send", "radix-k", "master"] {
        for (k, s) in [&s1, &s2].into_iter().enumerate() {
            let args = ["--nodes", "4", "--subvolumes", "2", "--compositor", comp];
            let (input, cfg) = config(s, &args).unwrap();
            let threads = run(&input, &cfg).unwrap();
            assert!(
                threads.image.pixels.iter().any(|p| p[3] > 0.2),
                "a visible frame"
            );
            let (procs, m) = remote(&workers).run(&input, &cfg).unwrap();
            assert_eq!(bits(&procs.image), bits(&threads.image), "{comp} view {k}");
            assert_eq!(
                procs.report.rounds, threads.report.rounds,
                "{comp} view {k}"
            );
            assert!(procs.report.bytes_total > 0);
            assert_eq!(m.layer_bytes, threads.report.bytes_total, "{comp}");
            if comp != "binary-swap" || k > 0 {
                assert_eq!(m.bricks_cached, 4, "{comp} view {k}");
                assert_eq!(procs.report.textures_cached, 8, "{comp} view {k}");
            }
        }
    }
}

#[test]
fn remote_grid_runs_refuse_what_they_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene(dir.path(), "[60, -50, 70]");
    let e = config(
        &s,
        &[
            "--nodes",
            "4",
            "--master",
            "--compositor",
            "direct-send",
            "--transport",
            "processes",
        ],
    )
    .err()
    .expect("refused");
    assert!(e.to_string().contains("--master"), "{e}");
    // binary-swap is the default compositor, but said aloud beside
    // --master it is a conflict, not something to drop silently.
    let e = config(
        &s,
        &["--nodes", "4", "--master", "--compositor", "binary-swap"],
    )
    .err()
    .expect("refused");
    assert!(e.to_string().contains("--compositor binary-swap"), "{e}");
    assert!(config(&s, &["--nodes", "4", "--master", "--compositor", "master"]).is_ok());
    let e = config(
        &s,
        &["--nodes", "2", "--workers", "127.0.0.1:1,127.0.0.1:2"],
    )
    .err()
    .expect("refused");
    assert!(e.to_string().contains("--transport tcp"), "{e}");
    let e = config(&s, &["--tolerance", "0.1"]).err().expect("refused");
    assert!(e.to_string().contains("--blocks"), "{e}");
    // A worker that cannot be reached: an error naming it, not a hang.
    let (input, cfg) = config(&s, &["--nodes", "1", "--subvolumes", "1", "--master"]).unwrap();
    let r = GridRemote {
        workers: vec!["127.0.0.1:9".into()],
        token: pvrsim::net::tcp::Token::none(),
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(5),
        transport: "tcp".into(),
        reassign: false,
    };
    let e = r.run(&input, &cfg).unwrap_err();
    assert!(e.to_string().contains("grid worker 0"), "{e:#}");
}

/// `pvrsim cluster --frames 3` over worker processes: the workers serve
/// one session a frame, so every frame completes; with the cache the later
/// frames reuse all 8 textures, with `--no-texture-cache` none, and the
/// images are the same bit for bit.
#[test]
fn grid_frames_over_worker_processes_all_complete() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene(dir.path(), "[60, -50, 70]");
    let mut pngs = Vec::new();
    for (cache, kept) in [(true, "[0, 8, 8]"), (false, "[0, 0, 0]")] {
        let png = dir.path().join(format!("frames-{cache}.png"));
        let mut cmd = std::process::Command::new(EXE);
        cmd.args(["cluster", s.to_str().unwrap(), "--nodes", "4"])
            .args(["--subvolumes", "2", "--transport", "processes"])
            .args(["--frames", "3", "--no-baselines", "--output"])
            .arg(&png);
        if !cache {
            cmd.arg("--no-texture-cache");
        }
        let out = cmd.output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "cache {cache}: {text}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(text.contains("3 frames, wall seconds each"), "{text}");
        assert!(
            text.contains(&format!("bricks from kept textures each: {kept}")),
            "cache {cache}: {text}"
        );
        pngs.push(std::fs::read(&png).unwrap());
    }
    assert_eq!(pngs[0], pngs[1], "the cache changes no pixel");
}
