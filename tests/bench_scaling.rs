//! `pvrsim bench --scaling` on two tiny points: the CSV has its columns, one
//! row per (cells, image size), every value finite and positive where it
//! must be, and the plots are written.

use std::process::Command;

const COLUMNS: &[&str] = &[
    "cells",
    "image",
    "threads",
    "file_bytes",
    "gen_s",
    "gen_peak_rss_bytes",
    "load_s",
    "project_s",
    "scan_s",
    "composite_s",
    "total_s",
    "process_s",
    "peak_rss_bytes",
    "bytes_per_tet",
];

#[test]
fn tiny_scaling_run_writes_a_sane_csv_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let out = dir.path().join("out");
    let run = || {
        Command::new(env!("CARGO_BIN_EXE_pvrsim"))
            .args(["bench", "--scaling", "--scaling-cells", "3000,12000,50000"])
            .args(["--max-cells", "20000", "--scaling-sizes", "48,96"])
            .arg("--scaling-cache")
            .arg(&cache)
            .arg("--scaling-out")
            .arg(&out)
            .output()
            .unwrap()
    };
    let o = run();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("skipping 50000 cells"), "{err}");
    let text = std::fs::read_to_string(out.join("scaling.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header, COLUMNS);
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 4, "2 cell counts x 2 sizes:\n{text}");
    for r in &rows {
        assert_eq!(r.len(), COLUMNS.len());
        assert!(r.iter().all(|v| v.is_finite() && *v >= 0.0), "{r:?}");
        for (k, name) in COLUMNS.iter().enumerate() {
            if *name != "composite_s" {
                assert!(r[k] > 0.0, "{name} not positive in {r:?}");
            }
        }
        assert!(r[0] > 2000.0 && r[0] < 20000.0, "cells {}", r[0]);
        assert!([48.0, 96.0].contains(&r[1]));
        let per_tet = r[12] / r[0];
        assert!((per_tet - r[13]).abs() < 0.01, "bytes_per_tet {r:?}");
    }
    assert!(rows[2][0] > rows[0][0], "ascending cell counts");
    for p in ["scaling-times.png", "scaling-memory.png"] {
        assert!(std::fs::metadata(out.join(p)).unwrap().len() > 1000, "{p}");
    }
    // A second run reuses the cached meshes: no generation, gen columns 0.
    let o = run();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("reusing"));
    let text = std::fs::read_to_string(out.join("scaling.csv")).unwrap();
    for l in text.lines().skip(1) {
        let v: Vec<&str> = l.split(',').collect();
        assert_eq!(v[4].parse::<f64>().unwrap(), 0.0);
        assert_eq!(v[5], "0");
    }
}
