//! The command line as a careful user meets it (issue 8): one test per item.
//! Every test runs the binary on the bundled `tests/data` scenes, in a
//! temporary directory; the whole file runs in well under 30 s.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const EXE: &str = env!("CARGO_BIN_EXE_pvrsim");

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn small_b() -> String {
    data("aorta-small-view-b.toml").display().to_string()
}

/// Runs `pvrsim ARGS` in `dir`.
fn run_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(EXE)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run pvrsim")
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Asserts a failure with exit code 1 whose stderr holds every `needle`.
fn fails_with(o: &Output, needles: &[&str]) {
    let (out, err) = text(o);
    assert_eq!(o.status.code(), Some(1), "stdout: {out}\nstderr: {err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in stderr: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

// ---------------------------------------------------------------- item 1

#[test]
fn item1_silent_no_ops_and_clamps_are_errors_or_warnings() {
    let d = tempfile::tempdir().unwrap();
    let s = small_b();
    for (args, needle) in [
        (vec!["--ert", "1.5"], "--ert 1.5: must be in (0, 1]"),
        (vec!["--ert", "0"], "--ert 0: must be in (0, 1]"),
        (
            vec!["--ert-update", "0"],
            "--ert-update 0: must be at least 1",
        ),
        (
            vec!["--ert-table", "0"],
            "--ert-table 0: must be at least 1",
        ),
        (vec!["--tile", "0"], "--tile 0: must be at least 1"),
        (
            vec!["--ert-entry-px", "0"],
            "--ert-entry-px 0: must be at least 1",
        ),
    ] {
        let mut a = vec!["render", s.as_str()];
        a.extend(args);
        fails_with(&run_in(d.path(), &a), &[needle]);
    }
    for (args, needle) in [
        (
            vec!["--ert", "1", "--share"],
            "--share needs early ray termination",
        ),
        (
            vec!["--ert", "1", "--sharing", "overlap"],
            "--sharing manager|overlap needs early ray termination",
        ),
        (
            vec!["--share-levels", "4"],
            "level sharing) needs sharing through the manager",
        ),
        (vec!["--ert-update", "0"], "--ert-update 0"),
    ] {
        let mut a = vec!["cluster", s.as_str()];
        a.extend(args);
        fails_with(&run_in(d.path(), &a), &[needle]);
    }
    // Options that do nothing in a combination say so.
    let o = run_in(d.path(), &["render", &s, "--ert", "1", "--ert-table", "4"]);
    assert!(o.status.success());
    assert!(text(&o)
        .1
        .contains("warning: --ert-table has no effect: ERT is off"));
    let o = run_in(
        d.path(),
        &[
            "cluster",
            &s,
            "--nodes",
            "2",
            "--clock",
            "wall",
            "--network",
            "gbe",
            "--profile",
            "pentium4",
            "--no-baselines",
        ],
    );
    assert!(o.status.success(), "{:?}", text(&o));
    let err = text(&o).1;
    assert!(
        err.contains("warning: --network gbe has no effect"),
        "{err}"
    );
    assert!(
        err.contains("warning: --profile pentium4 has no effect"),
        "{err}"
    );
    // render and cluster agree on the ERT default (the scene contract's 0.99).
    let o = run_in(
        d.path(),
        &[
            "cluster",
            &s,
            "--nodes",
            "2",
            "--no-baselines",
            "--report",
            "r.json",
        ],
    );
    assert!(o.status.success(), "{:?}", text(&o));
    let near = |v: &serde_json::Value| (v.as_f64().unwrap() - 0.99).abs() < 1e-6;
    assert!(near(&json(&d.path().join("r.json"))["ert_threshold"]));
    let o = run_in(d.path(), &["render", &s, "--stats", "s.json"]);
    assert!(o.status.success());
    assert!(near(&json(&d.path().join("s.json"))["ert_threshold"]));
}

// ---------------------------------------------------------------- item 2

/// Runs with stdout a pipe whose reading end is closed at once.
fn run_closed_stdout(dir: &Path, args: &[&str]) -> Output {
    let mut child = Command::new(EXE)
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    child.wait_with_output().unwrap()
}

#[test]
fn item2_closed_pipe_is_a_normal_stop_and_huge_frames_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let spx = data("spx.inp").display().to_string();
    let s = small_b();
    for args in [vec!["info", spx.as_str()], vec!["render", s.as_str()]] {
        let o = run_closed_stdout(d.path(), &args);
        let err = text(&o).1;
        assert_eq!(o.status.code(), Some(0), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let o = run_in(
        d.path(),
        &["render", &s, "--width", "60000", "--height", "60000"],
    );
    fails_with(&o, &["60000x60000 frame needs at least", "available"]);
    assert!(!d.path().join("out.png").exists());
    let o = run_in(
        d.path(),
        &["render", &s, "--width", "65536", "--height", "65536"],
    );
    fails_with(&o, &["pixels is more than pvrsim supports"]);
    let o = run_in(
        d.path(),
        &[
            "cluster", &s, "--nodes", "60000", "--width", "2000", "--height", "2000",
        ],
    );
    fails_with(&o, &["needs at least", "fewer --nodes"]);
}

// ---------------------------------------------------------------- item 3

#[test]
fn item3_demo_parameters_are_checked_and_nothing_broken_is_written() {
    let d = tempfile::tempdir().unwrap();
    for cells in ["0", "10", "100"] {
        let o = run_in(d.path(), &["demo", "--cells", cells, "--out-dir", "dm"]);
        fails_with(&o, &["--cells", "must be between 1000"]);
        assert!(!d.path().join("dm/demo.toml").exists());
    }
}

// ---------------------------------------------------------------- item 4

#[test]
fn item4_output_paths_are_checked_before_work() {
    let d = tempfile::tempdir().unwrap();
    let s = small_b();
    // A typo does not create a tree.
    let o = run_in(d.path(), &["render", &s, "-o", "no/such/dir/x.png"]);
    fails_with(&o, &["at most one missing level"]);
    assert!(!d.path().join("no").exists());
    let o = run_in(d.path(), &["render", &s, "--stats", "a/b/s.json"]);
    fails_with(&o, &["--stats a/b/s.json"]);
    // The format is checked before the render.
    let o = run_in(d.path(), &["render", &s, "-o", "out.jpg"]);
    fails_with(&o, &[".jpg is not supported"]);
    assert!(!text(&o).0.contains("cell projection"), "rendered first");
    let o = run_in(d.path(), &["cluster", &s, "--report", "r.txt"]);
    fails_with(&o, &["--report r.txt", "JSON"]);
    // One missing level is created, and said.
    let o = run_in(d.path(), &["render", &s, "-o", "new/x.png"]);
    assert!(o.status.success());
    assert!(text(&o).1.contains("note: created directory new"));
    assert!(d.path().join("new/x.png").exists());
    // A camera that sees nothing: a warning.
    let scene = std::fs::read_to_string(data("spx.toml")).unwrap();
    let away = scene
        .replace(
            "path  = \"spx.inp\"",
            &format!("path = {:?}", data("spx.inp").display().to_string()),
        )
        .replace("eye        = [7.0303,", "eye        = [107.0303,")
        .replace("target     = [7.0303,", "target     = [107.0303,");
    std::fs::write(d.path().join("away.toml"), away).unwrap();
    let o = run_in(d.path(), &["render", "away.toml", "-o", "away.png"]);
    assert!(o.status.success());
    let err = text(&o).1;
    assert!(
        err.contains("warning: the image is empty") && err.contains("0 cells projected"),
        "{err}"
    );
}

// ---------------------------------------------------------------- item 5

#[test]
fn item5_summaries_are_honest() {
    let d = tempfile::tempdir().unwrap();
    let s = small_b();
    let o = run_in(
        d.path(),
        &[
            "cluster", &s, "--nodes", "4", "--ert", "0.9", "--share", "--report", "v.json",
        ],
    );
    let (out, _) = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(
        out.contains("virtual clock (modelled times: network gbe, profile pentium4)"),
        "{out}"
    );
    assert!(
        out.contains("speed-up: frame-based") && out.contains("Tsc-based"),
        "{out}"
    );
    assert!(
        out.contains("terms: Tsc = ") && out.contains("share efficiency = "),
        "{out}"
    );
    let r = json(&d.path().join("v.json"));
    let seq = r["sequential_s"].as_f64().unwrap();
    let frame = r["frame_s"].as_f64().unwrap();
    let tsc = r["tsc_max_s"].as_f64().unwrap();
    assert!((r["speedup_frame"].as_f64().unwrap() - seq / frame).abs() < 1e-9);
    assert!((r["speedup"].as_f64().unwrap() - seq / tsc).abs() < 1e-9);
    // Wall clock: host times only; the models are not named.
    let o = run_in(
        d.path(),
        &[
            "cluster", &s, "--nodes", "2", "--clock", "wall", "--report", "w.json", "--trace",
            "t.json",
        ],
    );
    let (out, _) = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(
        out.contains("wall clock (times measured on this host"),
        "{out}"
    );
    assert!(!out.contains("gbe") && !out.contains("pentium4"), "{out}");
    let r = json(&d.path().join("w.json"));
    assert_eq!(r["network"], "n/a (wall clock)");
    assert!(r["nodes"][0]["composite_s"].is_null());
    // The timeline ends where the report's frame ends (one clock).
    let t = json(&d.path().join("t.json"));
    let end_us = t
        .as_array()
        .or_else(|| t["traceEvents"].as_array())
        .unwrap()
        .iter()
        .filter_map(|e| Some(e["ts"].as_f64()? + e["dur"].as_f64().unwrap_or(0.0)))
        .fold(0.0f64, f64::max);
    let frame_us = 1e6 * r["frame_s"].as_f64().unwrap();
    assert!(
        (end_us - frame_us).abs() <= 1e-3 * frame_us + 1.0,
        "{end_us} vs {frame_us}"
    );
    // --help says what the terms mean.
    let (help, _) = text(&run_in(d.path(), &["cluster", "--help"]));
    let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        help.contains("ideal speed-up") && help.contains("share efficiency"),
        "{help}"
    );
    assert!(help.contains("Default 0.99"), "{help}");
}

// ---------------------------------------------------------------- item 6

#[test]
fn item6_shipped_profiles_are_not_overwritten_and_profiles_load_at_run_time() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let shipped = root.join("configs/profiles/pentium4.toml");
    let before = std::fs::read(&shipped).unwrap();
    let o = run_in(
        root,
        &[
            "calibrate",
            "--table1",
            "--no-measure",
            "--base",
            "configs/profiles/calibrated.toml",
            "--pentium4-out",
            "configs/profiles/pentium4.toml",
        ],
    );
    fails_with(&o, &["shipped profile", "--force", "next build"]);
    assert_eq!(std::fs::read(&shipped).unwrap(), before);
    let o = run_in(
        root,
        &["calibrate", "--out", "configs/profiles/calibrated.toml"],
    );
    fails_with(&o, &["shipped profile"]);
    // A profile file is read at run time, and named in the report.
    let d = tempfile::tempdir().unwrap();
    let mine = d.path().join("mine.toml");
    std::fs::copy(&shipped, &mine).unwrap();
    let o = run_in(
        d.path(),
        &[
            "cluster",
            &small_b(),
            "--nodes",
            "2",
            "--no-baselines",
            "--profile",
            "mine.toml",
            "--report",
            "r.json",
        ],
    );
    assert!(o.status.success(), "{:?}", text(&o));
    assert_eq!(json(&d.path().join("r.json"))["profile"], "mine.toml");
    let o = run_in(d.path(), &["cluster", &small_b(), "--profile", "nope.toml"]);
    fails_with(&o, &["--profile nope.toml"]);
    let ignore = std::fs::read_to_string(root.join(".gitignore")).unwrap();
    assert!(ignore.lines().any(|l| l == "/demo"), "{ignore}");
}

// ---------------------------------------------------------------- item 7

#[test]
fn item7_compare_gives_a_verdict_and_a_labelled_strip() {
    let d = tempfile::tempdir().unwrap();
    let o = run_in(
        d.path(),
        &[
            "render",
            &small_b(),
            "--threads",
            "1",
            "--compare",
            "-o",
            "b.png",
            "--stats",
            "s.json",
        ],
    );
    let (out, _) = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(
        out.contains("verdict: WITHIN the bound")
            && out.contains("exact integrator 2/255 + ERT 2.54/255"),
        "{out}"
    );
    assert_eq!(
        json(&d.path().join("s.json"))["compare_verdict"]["within"],
        true
    );
    let strip = image::open(d.path().join("b-compare.png"))
        .unwrap()
        .to_rgb8();
    // Three 120-pixel columns (100-pixel images, widened for the labels), a 30-pixel label band.
    assert_eq!(strip.dimensions(), (3 * 120 + 12, 130));
    for x0 in [0u32, 126, 252] {
        let ink = (x0..x0 + 100)
            .flat_map(|x| (0..14).map(move |y| (x, y)))
            .filter(|&(x, y)| strip.get_pixel(x, y).0[0] < 128)
            .count();
        assert!(ink > 40, "no label over column at {x0}: {ink} dark pixels");
    }
    // Midpoint has no bound, and says so.
    let o = run_in(
        d.path(),
        &[
            "render",
            &small_b(),
            "--integrator",
            "midpoint",
            "--compare",
            "-o",
            "m.png",
        ],
    );
    assert!(text(&o)
        .0
        .contains("no bound applies to the midpoint integrator"));
}

// ---------------------------------------------------------------- item 8

#[test]
fn item8_piped_sweeps_print_a_line_per_run_and_dry_runs_estimate() {
    let d = tempfile::tempdir().unwrap();
    let cfg = d.path().join("tiny.toml");
    std::fs::write(
        &cfg,
        format!(
            "name = \"tiny\"\ncommand = \"render\"\nscene = {:?}\n[fixed]\nthreads = 1\n[vary]\ntile = [16, 32]\n",
            small_b()
        ),
    )
    .unwrap();
    let o = run_in(d.path(), &["sweep", "tiny.toml", "--dry-run"]);
    let (out, _) = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(
        out.contains("estimated duration ~") && out.contains("size model"),
        "{out}"
    );
    let o = run_in(d.path(), &["sweep", "tiny.toml"]);
    let (out, _) = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(out.contains("[1/2] tile=16 rep 0: ok in "), "{out}");
    assert!(out.contains("[2/2] tile=32 rep 0: ok in "), "{out}");
    // Options are validated for every run before the first.
    std::fs::write(
        &cfg,
        format!(
            "name = \"tiny\"\ncommand = \"render\"\nscene = {:?}\n[vary]\ntile = [16, 0]\n",
            small_b()
        ),
    )
    .unwrap();
    fails_with(
        &run_in(d.path(), &["sweep", "tiny.toml", "--force"]),
        &["--tile 0: must be at least 1"],
    );
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/sweeps.md"))
        .unwrap();
    assert!(!doc.contains("configs/fig11.toml") && !doc.contains("today `render`"));
}

// ---------------------------------------------------------------- item 9

#[test]
fn item9_scene_helper_writes_a_scene_that_renders() {
    let d = tempfile::tempdir().unwrap();
    let spx = data("spx.inp").display().to_string();
    for (name, extra) in [
        ("front", vec![]),
        (
            "persp",
            vec!["--view", "30,20", "--perspective", "35", "--size", "120x80"],
        ),
        ("top", vec!["--view", "+z"]),
    ] {
        let toml = format!("{name}.toml");
        let mut a = vec![
            "scene",
            spx.as_str(),
            "--field",
            "density",
            "-o",
            toml.as_str(),
        ];
        a.extend(extra);
        let o = run_in(d.path(), &a);
        assert!(o.status.success(), "{:?}", text(&o));
        let written = std::fs::read_to_string(d.path().join(&toml)).unwrap();
        assert!(
            written.starts_with("# Written by `pvrsim scene"),
            "{written}"
        );
        let png = format!("{name}.png");
        let o = run_in(
            d.path(),
            &["render", &toml, "-o", &png, "--stats", "s.json"],
        );
        let (_, err) = text(&o);
        assert!(o.status.success() && !err.contains("empty"), "{err}");
        let st = json(&d.path().join("s.json"));
        assert_eq!(
            st["cells_culled_offscreen"], 0,
            "{name}: the whole mesh is framed"
        );
        let img = image::open(d.path().join(&png)).unwrap().to_rgb8();
        let lit = img.pixels().filter(|p| p.0.iter().any(|&c| c > 10)).count();
        assert!(
            lit * 20 > img.pixels().len(),
            "{name}: only {lit} lit pixels"
        );
    }
    // The front view reproduces the hand-fitted tests/data/spx.toml camera.
    let t = std::fs::read_to_string(d.path().join("front.toml")).unwrap();
    assert!(
        t.contains("eye        = [7.030335, -22.740953, -3.972500]"),
        "{t}"
    );
    assert!(t.contains("height     = 10.334500"), "{t}");
    fails_with(
        &run_in(
            d.path(),
            &["scene", &spx, "--field", "density", "-o", "front.toml"],
        ),
        &["--force"],
    );
    fails_with(
        &run_in(
            d.path(),
            &["scene", &spx, "--field", "nope", "-o", "x.toml"],
        ),
        &["\"density\""],
    );
    fails_with(
        &run_in(
            d.path(),
            &[
                "scene", &spx, "--field", "density", "--view", "up", "-o", "x.toml",
            ],
        ),
        &["--view up"],
    );
}

// ---------------------------------------------------------------- item 10

#[test]
fn item10_nits() {
    let d = tempfile::tempdir().unwrap();
    let spx = data("spx.inp").display().to_string();
    let s = small_b();
    // info ends with a newline.
    let o = run_in(d.path(), &["info", &spx]);
    assert!(text(&o).0.ends_with('\n'));
    // "1 thread", not "1 threads".
    let o = run_in(d.path(), &["render", &s, "--threads", "1"]);
    let out = text(&o).0;
    assert!(
        out.contains(", 1 thread)") && !out.contains("1 threads"),
        "{out}"
    );
    // No "n/a s"; the culled cells are in the table.
    let o = run_in(d.path(), &["cluster", &s, "--nodes", "2", "--no-baselines"]);
    let out = text(&o).0;
    assert!(!out.contains("n/a s"), "{out}");
    assert!(
        out.lines()
            .any(|l| l.contains(" culled ") && l.contains("Tsc s")),
        "{out}"
    );
    // An error is printed once.
    let o = run_in(d.path(), &["render", "missing.toml"]);
    let err = text(&o).1;
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
    // A vector field is rendered as its magnitude, and the user is told.
    let vtk = data("aorta-small.vtk").display().to_string();
    let o = run_in(
        d.path(),
        &[
            "scene", &vtk, "--field", "velocity", "-o", "v.toml", "--size", "60x60",
        ],
    );
    assert!(o.status.success(), "{:?}", text(&o));
    let o = run_in(d.path(), &["render", "v.toml", "-o", "v.png"]);
    assert!(text(&o)
        .1
        .contains("field \"velocity\" has 3 components: rendering its magnitude"));
    // The timeline legend lists only the kinds drawn (no "compute" in a cluster run).
    let cli = <pvrsim::cli::Cli as clap::Parser>::try_parse_from([
        "pvrsim",
        "cluster",
        &s,
        "--nodes",
        "2",
        "--no-baselines",
    ])
    .unwrap();
    let pvrsim::cli::Command::Cluster(a) = cli.command else {
        panic!("not a cluster command")
    };
    let out = pvrsim::cli::cluster::execute(&a).unwrap();
    let kinds = pvrsim::cluster::timeline::kinds_shown(&out.trace);
    assert!(kinds.contains(&pvrsim::net::TraceKind::Scan));
    assert!(
        !kinds.contains(&pvrsim::net::TraceKind::Compute),
        "{kinds:?}"
    );
}
