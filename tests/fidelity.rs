//! The fast, non-root part of the fidelity check (the namespace part is
//! `scripts/fidelity-check.sh`, run by `scripts/ci-extra.sh` as root):
//! `pvrsim calibrate` works outside the checkout (built-in data), and with
//! the profile it fitted, the modelled phase-1 compute of each node of a
//! 4-node frame over worker processes is within 25 % of the node's measured
//! CPU time (median over nodes), for the mesh and the grid frame. CPU time,
//! not wall time: the test holds on a loaded machine.
//!
//! `cargo test --release --test fidelity`

use std::path::Path;
use std::process::Command;

fn pvrsim(dir: &Path, args: &[&str]) -> std::process::Output {
    let out = Command::new(env!("CARGO_BIN_EXE_pvrsim"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("pvrsim runs");
    assert!(
        out.status.success(),
        "pvrsim {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// One calibration and one fidelity run in `dir`: the median
/// modelled / measured CPU ratio per node of each workload, or the
/// first failure of a must-have (files, one row per node).
fn calibrate_and_compare(dir: &Path) -> Vec<(&'static str, Vec<f64>, f64)> {
    // No tests/data here: the calibration data is built in.
    pvrsim(dir, &["calibrate", "--repeats", "2", "--force"]);
    let profile = dir.join("profiles/calibrated.toml");
    let text = std::fs::read_to_string(&profile).unwrap();
    assert!(
        text.contains("per_sample") && text.contains("per_cell_setup"),
        "{text}"
    );
    let out = pvrsim(
        dir,
        &[
            "fidelity",
            "--workloads",
            "mesh,grid",
            "--mesh-variants",
            "ert-off",
            "--grid-variants",
            "binary-swap",
            "--nodes",
            "4",
            "--transports",
            "processes",
            "--repeats",
            "3",
            "--out",
            "fid",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("measured clock: cpu"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("fid/fidelity.json")).unwrap())
            .unwrap();
    for f in ["fidelity.csv", "fidelity-scan.png", "fidelity-render.png"] {
        assert!(dir.join("fid").join(f).exists(), "{f}");
    }
    [("mesh", "scan"), ("grid", "render")]
        .into_iter()
        .map(|(workload, phase)| {
            let mut ratios: Vec<f64> = json["rows"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|r| r["workload"] == workload && r["phase"] == phase && r["clock"] == "cpu")
                .map(|r| r["modelled_s"].as_f64().unwrap() / r["measured_s"].as_f64().unwrap())
                .collect();
            assert_eq!(ratios.len(), 4, "{workload}: one row per node");
            ratios.sort_by(f64::total_cmp);
            let median = 0.5 * (ratios[1] + ratios[2]);
            (workload, ratios, median)
        })
        .collect()
}

/// The band is 25 %. Calibration and frames run minutes apart on a
/// shared machine whose load changes CPU time too (caches, clock
/// frequency), so a run outside the band is tried once more, with a fresh
/// calibration: a model that is off fails both.
#[test]
fn calibrate_anywhere_then_compute_within_25_percent_of_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let mut tries = Vec::new();
    for _ in 0..2 {
        let r = calibrate_and_compare(dir.path());
        let ok = r.iter().all(|(_, _, m)| (m - 1.0).abs() <= 0.25);
        tries.push(r);
        if ok {
            return;
        }
        eprintln!("outside the band, calibrating again: {:?}", tries.last());
    }
    panic!("modelled / measured CPU per node (workload, ratios, median), both tries: {tries:?}");
}

#[test]
fn bad_options_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_pvrsim"))
            .current_dir(dir.path())
            .args(args)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?} succeeded");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    assert!(run(&["fidelity", "--workloads", "volume"]).contains("--workloads"));
    assert!(run(&["fidelity", "--transports", "tcp", "--nodes", "2"]).contains("--workers"));
    assert!(run(&["fidelity", "--mesh-variants", "fast"]).contains("--mesh-variants"));
    assert!(run(&["fidelity", "--report-only", "--out", "nothing"]).contains("--report-only"));
    assert!(run(&["calibrate", "--scenes", "missing.toml"]).contains("--scenes"));
    assert!(run(&["calibrate", "--node"]).contains("--node"));
}
