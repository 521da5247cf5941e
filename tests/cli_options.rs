//! The command line as a careful user meets it (issue 8), part 1: what
//! options mean and what is refused (items 1, 2, 3, 5, 6). Every test runs
//! the binary on the bundled `tests/data` scenes in a temporary directory.

mod cli_support;

use std::path::Path;
use std::process::{Command, Output, Stdio};

use cli_support::*;

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
        (vec!["--manager-shards", "2"], "--manager-shards needs"),
        (
            vec!["--ert", "0.9", "--share", "--manager-shards", "0"],
            "--manager-shards 0: must be at least 1",
        ),
        (
            vec!["--ert", "0.9", "--share", "--manager-shards", "100000"],
            "--manager-shards must be between 1 and the number of 16x16 screen tiles",
        ),
        (
            vec![
                "--ert",
                "0.9",
                "--share",
                "--paper",
                "--manager-shards",
                "2",
            ],
            "--manager-shards 2 with --paper",
        ),
        (
            vec![
                "--ert",
                "0.9",
                "--share",
                "--data",
                "partitioned",
                "--schedule-waves",
                "4",
            ],
            "--schedule-waves needs replicated data",
        ),
        (
            vec!["--ert", "0.9", "--share", "--schedule-leaf-cells", "0"],
            "--schedule-leaf-cells 0: must be at least 1",
        ),
        (
            vec!["--ert", "0.9", "--share", "--schedule-min-stacking=-1"],
            "--schedule-min-stacking must be a fraction >= 0",
        ),
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
