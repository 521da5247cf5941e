//! The persistent cluster session (`pvrsim::job::Session`, and `pvrsim
//! cluster --frames` on it): worker processes set up once for a whole
//! series (one set-up each, whatever the frame count), every frame equal to
//! the one-off frame at its camera; the typed API's frames at different
//! cameras, image sizes and transfer functions; a series stopped by SIGINT
//! keeps its finished frames, leaves no worker and no temp folder, and
//! `--resume` finishes it with the frames of an uninterrupted run.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use pvrsim::job::{ClusterJob, FrameRequest, Session};

const EXE: &str = env!("CARGO_BIN_EXE_pvrsim");

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn job(opts: &[&str]) -> ClusterJob {
    let mut argv = vec![data("aorta-small-view-b.toml").display().to_string()];
    argv.extend(opts.iter().map(|s| s.to_string()));
    pvrsim::job::args::by_name::parse("pvrsim cluster", &argv).unwrap()
}

/// `img` as `pvrsim` writes it, decoded: RGBA bytes.
fn written(dir: &Path, img: &pvrsim::image::Image, name: &str) -> Vec<u8> {
    let p = dir.join(name);
    img.save_png(&p).unwrap();
    image::open(&p).unwrap().to_rgba8().into_raw()
}

/// One-off `pvrsim cluster` frame of `scene` with `opts`, as RGBA bytes.
fn one_off(dir: &Path, scene: &Path, opts: &[&str], name: &str) -> Vec<u8> {
    let png = dir.join(name);
    let st = Command::new(EXE)
        .arg("cluster")
        .arg(scene)
        .args(opts)
        .args(["--no-baselines", "-o"])
        .arg(&png)
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(st.success(), "{name}");
    image::open(&png).unwrap().to_rgba8().into_raw()
}

/// `scene` (the bundled view-B scene) with `camera` and `transfer` as the
/// session saw them, written into `dir`.
fn scene_at(dir: &Path, s: &pvrsim::scene::Scene, name: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(
        &p,
        s.to_toml(&data("aorta-small.vtk").display().to_string()),
    )
    .unwrap();
    p
}

#[test]
fn a_series_over_processes_sets_each_worker_up_once() {
    let dir = tempfile::tempdir().unwrap();
    let pattern = dir.path().join("f-%02d.png");
    let out = Command::new(EXE)
        .arg("cluster")
        .arg(data("aorta-small-view-b.toml"))
        .args([
            "-v",
            "--nodes",
            "3",
            "--ert",
            "1",
            "--canonical",
            "--transport",
            "processes",
            "--frames",
            "4",
            "--turn",
            "30",
            "--no-baselines",
            "-o",
        ])
        .arg(&pattern)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    // One session: each worker hears one set-up from the coordinator and
    // starts phase 1 once a frame.
    assert_eq!(err.matches("a set-up from").count(), 3, "{err}");
    assert_eq!(err.matches("phase 1 started").count(), 12, "{err}");
    // Lines arrive whole, prefixed by the rank.
    for l in err.lines().filter(|l| l.contains("phase 1 started")) {
        assert!(l.starts_with("pvrsim worker "), "{l}");
    }
    for k in 0..4 {
        assert!(
            dir.path().join(format!("f-{k:02}.png")).is_file(),
            "frame {k}"
        );
    }
}

#[test]
fn a_series_without_v_is_quiet() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(EXE)
        .arg("cluster")
        .arg(data("aorta-small-view-b.toml"))
        .args([
            "--nodes",
            "3",
            "--ert",
            "1",
            "--transport",
            "processes",
            "--frames",
            "6",
            "--turn",
            "10",
            "--no-baselines",
            "-o",
        ])
        .arg(dir.path().join("f-%02d.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(!err.contains("pvrsim worker"), "{err}");
    assert!(err.lines().count() <= 12, "{err}");
}

#[test]
fn session_frames_equal_one_off_frames() {
    let dir = tempfile::tempdir().unwrap();
    for transport in ["threads", "processes"] {
        let opts = [
            "--nodes",
            "3",
            "--ert",
            "1",
            "--canonical",
            "--transport",
            transport,
            "--no-baselines",
        ];
        let mut s = Session::open_with(
            &job(&opts),
            &pvrsim::cluster::remote::spawn::WorkerProgram::exe(Path::new(EXE)),
        )
        .unwrap();
        let base = s.scene().clone();
        let cams = pvrsim::scene::orbit(&base.camera, 4, 35.0);
        let mut tf = base.transfer.clone();
        for p in &mut tf.points {
            p.opacity *= 0.5;
        }
        let reqs = [
            FrameRequest::default(),
            FrameRequest {
                camera: Some(cams[1]),
                ..Default::default()
            },
            FrameRequest {
                camera: Some(cams[2]),
                size: Some((61, 47)),
                ..Default::default()
            },
            FrameRequest {
                camera: Some(cams[3]),
                transfer: Some(tf.clone()),
                size: Some((base.image.width, base.image.height)),
                ..Default::default()
            },
        ];
        let mut scene = base.clone();
        for (k, r) in reqs.iter().enumerate() {
            let out = s.frame(r).unwrap();
            if let Some(c) = r.camera {
                scene.camera = c;
            }
            if let Some(t) = &r.transfer {
                scene.transfer = t.clone();
            }
            if let Some((w, h)) = r.size {
                scene.image.width = w;
                scene.image.height = h;
            }
            let p = scene_at(dir.path(), &scene, &format!("{transport}-{k}.toml"));
            let cli: Vec<&str> = opts[..5].to_vec();
            let want = one_off(dir.path(), &p, &cli, &format!("{transport}-{k}.png"));
            let got = written(dir.path(), &out.image, &format!("{transport}-{k}-s.png"));
            assert_eq!(got, want, "{transport}, frame {k}");
        }
        assert_eq!(s.frames(), 4);
        let e = s
            .frame(&FrameRequest {
                step: Some(3),
                ..Default::default()
            })
            .unwrap_err();
        assert!(e.to_string().contains("time step 3 does not exist"), "{e}");
        s.close().unwrap();
    }
}

/// The ids of `pid`'s child processes.
fn children(pid: u32) -> Vec<u32> {
    let mut out = Vec::new();
    for t in std::fs::read_dir(format!("/proc/{pid}/task"))
        .into_iter()
        .flatten()
    {
        let p = t.unwrap().path().join("children");
        if let Ok(s) = std::fs::read_to_string(p) {
            out.extend(s.split_whitespace().filter_map(|x| x.parse::<u32>().ok()));
        }
    }
    out
}

fn alive(pid: u32) -> bool {
    // A zombie is gone for our purpose (its parent reaps it).
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .is_ok_and(|s| s.split_whitespace().nth(2).is_none_or(|st| st != "Z"))
}

#[test]
fn sigint_keeps_finished_frames_and_resume_finishes_the_series() {
    let dir = tempfile::tempdir().unwrap();
    let args = |pattern: &Path| -> Vec<String> {
        let mut v: Vec<String> = [
            "cluster",
            data("aorta-small-view-b.toml").to_str().unwrap(),
            "--nodes",
            "4",
            "--ert",
            "1",
            "--canonical",
            "--transport",
            "processes",
            "--frames",
            "36",
            "--turn",
            "10",
            "--no-baselines",
            "-o",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        v.push(pattern.display().to_string());
        v
    };
    let stopped = dir.path().join("s-%02d.png");
    let child = Command::new(EXE)
        .args(args(&stopped))
        .env("TMPDIR", dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    // Wait for two frames on disk, then interrupt the coordinator alone.
    let t0 = Instant::now();
    while !dir.path().join("s-01.png").is_file() {
        assert!(t0.elapsed() < Duration::from_secs(120), "no second frame");
        std::thread::sleep(Duration::from_millis(20));
    }
    let workers = children(pid);
    assert_eq!(workers.len(), 4, "{workers:?}");
    unsafe {
        libc::kill(pid as i32, libc::SIGINT);
    }
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("stopped after"), "{err}");
    assert!(err.contains("--resume"), "{err}");
    let t1 = Instant::now();
    while workers.iter().any(|&w| alive(w)) {
        assert!(
            t1.elapsed() < Duration::from_secs(5),
            "workers left running"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with("pvrsim-workers-"))
        .collect();
    assert!(left.is_empty(), "temp folders left: {left:?}");
    let done = (0..36)
        .take_while(|k| dir.path().join(format!("s-{k:02}.png")).is_file())
        .count();
    assert!((2..36).contains(&done), "{done} frames done");
    // Resume: the rest, equal to an uninterrupted run's frames.
    let st = Command::new(EXE)
        .args(args(&stopped))
        .arg("--resume")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(st.success());
    let whole = dir.path().join("w-%02d.png");
    let st = Command::new(EXE)
        .args(args(&whole))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(st.success());
    for k in 0..36 {
        let a = image::open(dir.path().join(format!("s-{k:02}.png"))).unwrap();
        let b = image::open(dir.path().join(format!("w-{k:02}.png"))).unwrap();
        assert_eq!(a.to_rgba8().as_raw(), b.to_rgba8().as_raw(), "frame {k}");
    }
}
