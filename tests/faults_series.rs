//! Issue 54: faults in a series. A 5-frame orbit on 4 workers with
//! `--on-failure reassign`, over `--transport processes` and over `tcp`
//! workers: worker 2 is killed (`kill -9`) or stopped (`SIGSTOP`, never
//! continued) when phase 1 of the session's frame 2 starts (the hidden
//! worker hook `--test-kill-at-frame 2`). The series completes with every
//! frame written and each equal, byte for byte, to the undisturbed
//! series' frame (`--canonical --ert 1`); the report's series section
//! says in which frame which worker was lost (and in what phase); and the
//! frames after the loss run on the survivors' session (one set-up per
//! session: 4 at the start, 3 for the retry, none after). Heartbeat
//! deadline 1 s.

use std::path::Path;
use std::time::Duration;

mod transport_support;
use transport_support::*;

const FRAMES: usize = 5;

/// The series' options (no transport, no output).
fn common(scene: &Path) -> Vec<String> {
    let mut v = vec![scene.display().to_string()];
    v.extend(
        [
            "-v",
            "--nodes",
            "4",
            "--canonical",
            "--ert",
            "1",
            "--no-baselines",
            "--frames",
            "5",
            "--turn",
            "30",
            "--heartbeat-timeout",
            "1",
            "--on-failure",
            "reassign",
        ]
        .map(String::from),
    );
    v
}

/// Runs `pvrsim cluster` with `args` writing `dir/f-NN.png` and
/// `dir/r.json` (at most 60 s); its stderr. Panics on failure.
fn series(case: &str, args: &[String], dir: &Path) -> String {
    let mut a: Vec<String> = args.to_vec();
    a.extend([
        "-o".into(),
        dir.join("f-%02d.png").display().to_string(),
        "--report".into(),
        dir.join("r.json").display().to_string(),
    ]);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    let (ok, err, secs) = cluster_cli(&a, Duration::from_secs(60));
    assert!(ok, "{case}: failed after {secs:.1} s\n{err}");
    eprintln!("{case}: {secs:.1} s");
    err
}

/// The frames of a series in `dir`, decoded (RGBA bytes).
fn frames(case: &str, dir: &Path) -> Vec<Vec<u8>> {
    (0..FRAMES)
        .map(|k| {
            let p = dir.join(format!("f-{k:02}.png"));
            image::open(&p)
                .unwrap_or_else(|e| panic!("{case}: frame {k}: {}: {e}", p.display()))
                .to_rgba8()
                .into_raw()
        })
        .collect()
}

/// The undisturbed series over processes.
fn reference(scene: &Path) -> (tempfile::TempDir, Vec<Vec<u8>>) {
    let dir = tempfile::tempdir().unwrap();
    let mut a = common(scene);
    a.extend(["--transport".into(), "processes".into()]);
    series("undisturbed", &a, dir.path());
    let f = frames("undisturbed", dir.path());
    (dir, f)
}

/// The checks of a disturbed series in `dir` (stderr `err`, the workers'
/// set-up lines `setups`): every frame equal to the reference's, the loss
/// in frame 1 (the session's frame 2) and only there, 7 set-ups.
fn check(case: &str, dir: &Path, reference: &[Vec<u8>], setups: usize) {
    let got = frames(case, dir);
    for (k, (g, r)) in got.iter().zip(reference).enumerate() {
        assert!(g == r, "{case}: frame {k} differs from the undisturbed one");
    }
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("r.json")).unwrap()).unwrap();
    let rows = report["series"]["frames"]
        .as_array()
        .expect("series frames");
    assert_eq!(rows.len(), FRAMES, "{case}");
    for (k, row) in rows.iter().enumerate() {
        let re = &row["reassigned"];
        if k != 1 {
            assert!(re.is_null(), "{case}: a loss in frame {k}: {re}");
            continue;
        }
        let ev = &re["events"][0];
        assert_eq!(
            re["events"].as_array().map(Vec::len),
            Some(1),
            "{case}: {re}"
        );
        assert_eq!(ev["phase"], "phase 1", "{case}: {re}");
        let who = ev["workers"][0].as_str().unwrap_or_default();
        assert!(who.starts_with("worker 2 "), "{case}: {re}");
        assert_eq!(ev["survivors"], 3, "{case}: {re}");
        assert!(ev["moved"].as_u64().unwrap_or(0) > 0, "{case}: {re}");
    }
    // The last frame ran on the 3 survivors.
    assert_eq!(report["n_nodes"], 3, "{case}");
    // One session of 4, one of the 3 survivors (the retry), kept for the
    // frames after it: no set-up per frame.
    assert_eq!(setups, 7, "{case}: set-ups");
}

#[test]
fn a_series_over_processes_loses_no_frame_to_a_lost_worker() {
    let scene = data("aorta-small-view-b.toml");
    let (_r, reference) = reference(&scene);
    for stop in [false, true] {
        let case = format!("processes, stop {stop}");
        let dir = tempfile::tempdir().unwrap();
        let mut a = common(&scene);
        let hook = if stop {
            "2:--test-stop --test-kill-at-frame 2"
        } else {
            "2:--test-kill-at-frame 2"
        };
        a.extend(["--transport", "processes", "--test-worker-hook", hook].map(String::from));
        let err = series(&case, &a, dir.path());
        assert!(
            err.contains("at frame 2 of its session"),
            "{case}: no hook\n{err}"
        );
        check(
            &case,
            dir.path(),
            &reference,
            err.matches("a set-up from").count(),
        );
    }
}

#[test]
fn a_series_over_tcp_loses_no_frame_to_a_lost_worker() {
    let scene = data("aorta-small-view-b.toml");
    let (_r, reference) = reference(&scene);
    for stop in [false, true] {
        let case = format!("tcp, stop {stop}");
        let mut hook = vec!["--heartbeat-timeout", "1"];
        if stop {
            hook.push("--test-stop");
        }
        hook.extend(["--test-kill-at-frame", "2"]);
        let workers: Vec<WorkerProc> = (0..4)
            .map(|k| {
                let a: &[&str] = if k == 2 {
                    &hook
                } else {
                    &["--heartbeat-timeout", "1"]
                };
                WorkerProc::start_with(None, a, false)
            })
            .collect();
        let addrs: Vec<&str> = workers.iter().map(|w| w.addr.as_str()).collect();
        let dir = tempfile::tempdir().unwrap();
        let mut a = common(&scene);
        a.extend([
            "--transport".into(),
            "tcp".into(),
            "--workers".into(),
            addrs.join(","),
        ]);
        series(&case, &a, dir.path());
        // The workers' own logs (-v): set-ups, and worker 2's hook.
        let logs: Vec<Vec<String>> = workers
            .iter()
            .map(|w| w.lines.try_iter().collect())
            .collect();
        assert!(
            logs[2]
                .iter()
                .any(|l| l.contains("at frame 2 of its session")),
            "{case}: no hook: {:?}",
            logs[2]
        );
        let setups = logs
            .iter()
            .flatten()
            .filter(|l| l.contains("a set-up from"))
            .count();
        check(&case, dir.path(), &reference, setups);
    }
}
