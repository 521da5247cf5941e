//! Frame series of a mesh scene (`pvrsim cluster --frames N --turn DEG`):
//! every frame equals the one-off frame at its camera (virtual clock with
//! ERT, sharing and DLB; threads and worker processes with ERT off and
//! `--canonical`); the report's `series` section; worker processes receive
//! the cells once; bad series options are refused before any frame runs.

use std::path::{Path, PathBuf};
use std::process::Command;

use pvrsim::job::{ClusterJob, ClusterResult};

const EXE: &str = env!("CARGO_BIN_EXE_pvrsim");

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The aorta-small view-B scene with its eye moved to `eye`, written into
/// `dir` (the mesh path made absolute).
fn scene_with_eye(dir: &Path, eye: [f64; 3]) -> PathBuf {
    let text = std::fs::read_to_string(data("aorta-small-view-b.toml")).unwrap();
    let mesh = data("aorta-small.vtk");
    let text = text
        .replace(
            "path  = \"aorta-small.vtk\"",
            &format!("path  = {:?}", mesh.display().to_string()),
        )
        .replace(
            "eye        = [-2.5, 0, 232.7]",
            &format!("eye        = [{:?}, {:?}, {:?}]", eye[0], eye[1], eye[2]),
        );
    assert!(text.contains("eye        = ["), "scene changed");
    let p = dir.join(format!("eye-{:.3}-{:.3}.toml", eye[0], eye[2]));
    std::fs::write(&p, text).unwrap();
    p
}

fn job(scene: &Path, opts: &[(&str, &str)]) -> ClusterJob {
    let options: Vec<(String, pvrsim::job::args::by_name::ParamValue)> =
        std::iter::once(("scene".to_string(), scene.display().to_string().into()))
            .chain(opts.iter().map(|(k, v)| (k.to_string(), value(v))))
            .collect();
    ClusterJob::from_options(&options).unwrap()
}

/// An option's value as a job file would type it.
fn value(v: &str) -> pvrsim::job::args::by_name::ParamValue {
    if v == "true" {
        true.into()
    } else if let Ok(i) = v.parse::<i64>() {
        i.into()
    } else if let Ok(f) = v.parse::<f64>() {
        f.into()
    } else {
        v.into()
    }
}

fn frames(r: ClusterResult) -> Vec<pvrsim::cluster::ClusterOutcome> {
    match r {
        ClusterResult::Mesh(f) => f,
        ClusterResult::Grid(_) => panic!("a mesh scene"),
    }
}

fn bits(img: &pvrsim::image::Image) -> Vec<u32> {
    img.pixels
        .iter()
        .flat_map(|p| p.iter().map(|c| c.to_bits()))
        .collect()
}

/// Each frame of a series equals the one-off frame at that camera.
fn frames_equal_one_offs(opts: &[(&str, &str)]) {
    let dir = tempfile::tempdir().unwrap();
    let mut series_opts = opts.to_vec();
    series_opts.extend([("frames", "3"), ("turn", "40")]);
    let series = frames(
        job(&data("aorta-small-view-b.toml"), &series_opts)
            .run()
            .unwrap(),
    );
    assert_eq!(series.len(), 3);
    let s = series[2].report.series.as_ref().expect("a series section");
    assert_eq!(s.frames.len(), 3);
    for (k, out) in series.iter().enumerate() {
        let eye = s.frames[k].eye;
        let one = frames(job(&scene_with_eye(dir.path(), eye), opts).run().unwrap());
        assert_eq!(one.len(), 1);
        assert!(one[0].report.series.is_none());
        assert_eq!(
            bits(&out.image),
            bits(&one[0].image),
            "frame {k} differs from the one-off frame ({opts:?})"
        );
        assert!(
            out.image.pixels.iter().any(|p| p[3] > 0.0),
            "frame {k} empty"
        );
    }
    // The frames differ from each other (the camera turned).
    assert_ne!(bits(&series[0].image), bits(&series[1].image));
}

#[test]
fn virtual_clock_frames_equal_one_offs_with_ert_sharing_and_dlb() {
    frames_equal_one_offs(&[
        ("nodes", "4"),
        ("ert", "0.9"),
        ("share", "true"),
        ("dlb", "true"),
        ("no-baselines", "true"),
    ]);
}

#[test]
fn thread_frames_equal_one_offs_canonical() {
    frames_equal_one_offs(&[
        ("nodes", "3"),
        ("ert", "1"),
        ("canonical", "true"),
        ("transport", "threads"),
        ("no-baselines", "true"),
    ]);
}

#[test]
fn carried_placement_keeps_canonical_frames_bit_for_bit() {
    // Partitioned data: coherence is on by default; DLB moves cells, the
    // next frame starts from where they went.
    let opts = [
        ("nodes", "4"),
        ("ert", "1"),
        ("canonical", "true"),
        ("dlb", "true"),
        ("data", "partitioned"),
        ("no-baselines", "true"),
    ];
    let mut with = opts.to_vec();
    with.extend([("frames", "3"), ("turn", "20")]);
    let a = frames(job(&data("aorta-small-view-b.toml"), &with).run().unwrap());
    with.push(("coherence", "off"));
    let b = frames(job(&data("aorta-small-view-b.toml"), &with).run().unwrap());
    let s = a[2].report.series.as_ref().unwrap();
    assert_eq!(s.coherence, pvrsim::cluster::series::Coherence::Placement);
    assert!(
        a[0].report.cells_moved > 0,
        "DLB moved nothing: the test tests nothing"
    );
    for k in 0..3 {
        assert_eq!(bits(&a[k].image), bits(&b[k].image), "frame {k}");
    }
    // The second frame started elsewhere: its counts differ.
    assert_ne!(
        a[1].report
            .nodes
            .iter()
            .map(|n| n.cells_initial)
            .collect::<Vec<_>>(),
        b[1].report
            .nodes
            .iter()
            .map(|n| n.cells_initial)
            .collect::<Vec<_>>()
    );
}

#[test]
fn the_series_section_has_fps_and_a_row_per_frame() {
    let out = frames(
        job(
            &data("aorta-small-view-b.toml"),
            &[
                ("nodes", "4"),
                ("frames", "4"),
                ("turn", "10"),
                ("no-baselines", "true"),
            ],
        )
        .run()
        .unwrap(),
    );
    let r = serde_json::to_value(&out[3].report).unwrap();
    let s = &r["series"];
    let rows = s["frames"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    let total: f64 = rows.iter().map(|f| f["frame_s"].as_f64().unwrap()).sum();
    assert!(total > 0.0);
    let fps = s["fps"].as_f64().unwrap();
    assert!((fps - 4.0 / total).abs() < 1e-9 * fps, "{fps} vs {total}");
    for (k, f) in rows.iter().enumerate() {
        assert_eq!(f["frame"].as_u64(), Some(k as u64));
        assert!(f["bytes"].as_u64().unwrap() > 0);
        // Each row is that frame's own report.
        assert_eq!(f["frame_s"].as_f64(), Some(out[k].report.frame_s));
    }
    assert_eq!(s["clock"], "virtual");
    // Earlier frames' reports carry no series section.
    assert!(serde_json::to_value(&out[0].report).unwrap()["series"].is_null());
}

#[test]
fn worker_processes_receive_the_cells_once_and_frames_match() {
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("r.json");
    let csv = dir.path().join("s.csv");
    let pattern = dir.path().join("f-%02d.png");
    let st = Command::new(EXE)
        .args(["cluster"])
        .arg(data("aorta-small-view-b.toml"))
        .args([
            "--nodes",
            "3",
            "--ert",
            "1",
            "--canonical",
            "--transport",
            "processes",
            "--heartbeat-timeout",
            "30",
            "--frames",
            "3",
            "--turn",
            "25",
            "--no-baselines",
        ])
        .arg("-o")
        .arg(&pattern)
        .arg("--report")
        .arg(&report)
        .arg("--series-csv")
        .arg(&csv)
        .status()
        .unwrap();
    assert!(st.success());
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let rows = r["series"]["frames"].as_array().unwrap().clone();
    assert_eq!(rows.len(), 3);
    assert_eq!(r["series"]["clock"], "wall");
    assert!(rows[0]["cells_bytes"].as_u64().unwrap() > 0);
    for f in &rows[1..] {
        assert_eq!(f["cells_bytes"].as_u64(), Some(0), "cells sent again: {f}");
        assert!(f["bytes"].as_u64().unwrap() < rows[0]["bytes"].as_u64().unwrap());
    }
    let lines = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(lines.lines().count(), 4, "{lines}");
    assert!(lines.starts_with("frame,data,eye_x,eye_y,eye_z,frame_s,"));
    // Every frame written, and each equals the one-off frame in this
    // process (canonical, ERT off: bit for bit).
    for (k, f) in rows.iter().enumerate() {
        let png = dir.path().join(format!("f-{k:02}.png"));
        let got = image::open(&png).unwrap().to_rgba8();
        let eye: Vec<f64> = f["eye"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let one_png = dir.path().join(format!("one-{k}.png"));
        let st = Command::new(EXE)
            .args(["cluster"])
            .arg(scene_with_eye(dir.path(), [eye[0], eye[1], eye[2]]))
            .args([
                "--nodes",
                "3",
                "--ert",
                "1",
                "--canonical",
                "--no-baselines",
            ])
            .arg("-o")
            .arg(&one_png)
            .status()
            .unwrap();
        assert!(st.success());
        let want = image::open(&one_png).unwrap().to_rgba8();
        assert_eq!(got.as_raw(), want.as_raw(), "frame {k}");
    }
}

fn refused(args: &[&str], needle: &str) {
    let out = Command::new(EXE)
        .arg("cluster")
        .arg(data("aorta-small-view-b.toml"))
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} accepted");
    assert!(err.contains(needle), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_series_options_are_refused_before_any_frame() {
    refused(&["--turn", "10"], "give --frames N");
    refused(&["--frames", "0"], "--frames must be at least 1");
    refused(&["--frames", "2", "--turn", "inf"], "finite");
    refused(&["--series-csv", "x.csv"], "give --frames N");
    refused(&["--frames", "2", "--series-csv", "x.txt"], "--series-csv");
    refused(
        &[
            "--frames",
            "2",
            "--coherence",
            "placement",
            "--transport",
            "processes",
        ],
        "--coherence placement runs in this process",
    );
    refused(&["--frames", "2", "--series", "s.toml"], "--series");
}

/// Runs `pvrsim cluster` on view B with `--series FILE` (text `series`),
/// returning (success, stderr, report).
fn run_series_file(dir: &Path, series: &str) -> (bool, String, Option<serde_json::Value>) {
    let file = dir.join("session.toml");
    std::fs::write(&file, series).unwrap();
    let report = dir.join("r.json");
    let _ = std::fs::remove_file(&report);
    let out = Command::new(EXE)
        .arg("cluster")
        .arg(data("aorta-small-view-b.toml"))
        .args(["--nodes", "2", "--no-baselines", "--series"])
        .arg(&file)
        .arg("-o")
        .arg(dir.join("f-%d.png"))
        .arg("--report")
        .arg(&report)
        .output()
        .unwrap();
    let r = std::fs::read_to_string(&report)
        .ok()
        .map(|t| serde_json::from_str(&t).unwrap());
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        r,
    )
}

#[test]
fn a_series_file_replays_cameras_transfer_functions_fields_and_time_steps() {
    let dir = tempfile::tempdir().unwrap();
    // A time step: the same mesh in another file (same topology).
    std::fs::copy(data("aorta-small.vtk"), dir.path().join("step1.vtk")).unwrap();
    let (ok, err, r) = run_series_file(
        dir.path(),
        "[[frame]]\n[[frame]]\nturn = 30\n[[frame]]\ntransfer = { unit_distance = 5, points = [[0, 0, 0, 1, 0.1], [1, 1, 0, 0, 0.9]] }\n[[frame]]\nfield = \"pressure\"\n[[frame]]\nmesh = \"step1.vtk\"\nfield = \"speed\"\nrepeat = 2\n",
    );
    assert!(ok, "{err}");
    let s = &r.unwrap()["series"];
    let rows = s["frames"].as_array().unwrap();
    assert_eq!(rows.len(), 6);
    let data_of: Vec<u64> = rows.iter().map(|f| f["data"].as_u64().unwrap()).collect();
    // The scene's speed, its pressure, then the time step's speed.
    assert_eq!(data_of, [0, 0, 0, 1, 2, 2]);
    let img = |k: usize| {
        image::open(dir.path().join(format!("f-{k}.png")))
            .unwrap()
            .to_rgba8()
            .into_raw()
    };
    // Each change shows; the time step (same data) gives frame 2's image
    // from frame 2's camera and transfer function, and repeats it.
    for k in 1..4 {
        assert_ne!(img(k), img(k - 1), "frame {k} did not change");
    }
    assert_eq!(img(4), img(2));
    assert_eq!(img(5), img(4));
}

#[test]
fn bad_series_files_are_refused_before_any_frame_runs() {
    let dir = tempfile::tempdir().unwrap();
    // Another topology: the 2-tet spx-like file is not available; write
    // a mesh with one cell fewer by taking view A's mesh (same file) is
    // not possible either, so use a tiny generated mesh.
    let other = dir.path().join("other.vtk");
    std::fs::write(
        &other,
        "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 4\nSCALARS speed float 1\nLOOKUP_TABLE default\n0 1 2 3\n",
    )
    .unwrap();
    for (series, needles) in [
        (
            "[[frame]]\nzoom = 2\n",
            &["session.toml", "line 2", "zoom"][..],
        ),
        (
            "[[frame]]\n[[frame]]\neye = [-2.5, 0, 0]\n",
            &["frame[1].eye", "same point"][..],
        ),
        (
            "[[frame]]\n[[frame]]\nmesh = \"missing.vtk\"\n",
            &["frame 1", "missing.vtk"][..],
        ),
        (
            "[[frame]]\n[[frame]]\nmesh = \"other.vtk\"\n",
            &["frame 1", "other.vtk", "4 vertices", "topology"][..],
        ),
        (
            "[[frame]]\nfield = \"temperature\"\n",
            &["frame 0", "temperature"][..],
        ),
    ] {
        let (ok, err, r) = run_series_file(dir.path(), series);
        assert!(!ok, "{series} accepted");
        for n in needles {
            assert!(err.contains(n), "{series}: {err} lacks {n}");
        }
        assert!(!err.contains("panicked"), "{err}");
        assert!(!err.contains("frame 1/"), "a frame ran: {err}");
        assert!(r.is_none(), "a report was written");
        assert!(!dir.path().join("f-0.png").exists(), "a frame was written");
    }
}

/// `--movie` runs ffmpeg on PATH over the frames; a stand-in script
/// records its arguments and writes the file (whether ffmpeg is installed
/// or not, the plumbing is tested).
#[cfg(unix)]
#[test]
fn movie_runs_ffmpeg_over_every_frame() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("bin");
    std::fs::create_dir(&bin).unwrap();
    let log = dir.path().join("args.txt");
    let fake = bin.join("ffmpeg");
    std::fs::write(
        &fake,
        format!(
            "#!/bin/sh\n[ \"$1\" = -version ] && exit 0\necho \"$@\" > {}\nfor a in \"$@\"; do last=$a; done\nls $(dirname \"$7\") | wc -l >> {}\necho movie > \"$last\"\n",
            log.display(),
            log.display()
        ),
    )
    .unwrap();
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
    let movie = dir.path().join("orbit.gif");
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = Command::new(EXE)
        .env("PATH", path)
        .arg("cluster")
        .arg(data("aorta-small-view-b.toml"))
        .args([
            "--nodes",
            "2",
            "--no-baselines",
            "--frames",
            "4",
            "--turn",
            "15",
        ])
        .args(["--movie-fps", "24", "--movie"])
        .arg(&movie)
        .arg("-o")
        .arg(dir.path().join("last.png"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(std::fs::read_to_string(&movie).unwrap(), "movie\n");
    let args = std::fs::read_to_string(&log).unwrap();
    assert!(args.contains("-framerate 24"), "{args}");
    // The stand-in counted the frames in the folder it was given.
    assert_eq!(args.lines().nth(1).map(str::trim), Some("4"), "{args}");
}
