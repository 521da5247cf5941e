//! `pvrsim bench --scaling --scaling-scenes`: the scaling benchmark on a
//! scene the user brings writes one row per (scene, image size) with the
//! per-cell and per-segment costs, and the option alone is refused.

use std::process::Command;

const COLUMNS: &str = "mesh,cells,image,threads,file_bytes,segments,load_s,project_s,scan_s,composite_s,project_ns_per_cell,scan_ns_per_segment,process_s,peak_rss_bytes,bytes_per_tet,mesh_bytes_per_tet,frame_bytes_per_tet";

fn pvrsim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pvrsim"))
}

#[test]
fn scaling_on_given_scenes_writes_their_rows() {
    let dir = tempfile::tempdir().unwrap();
    let demo = dir.path().join("d");
    let o = pvrsim()
        .args(["demo", "--cells", "4000", "--nodes", "0", "--out-dir"])
        .arg(&demo)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("out");
    let o = pvrsim()
        .args(["bench", "--scaling", "--scaling-sizes", "40,64"])
        .arg("--scaling-scenes")
        .arg(demo.join("demo.toml"))
        .arg("--scaling-out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(out.join("scaling-scenes.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), COLUMNS);
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2, "1 scene x 2 sizes:\n{text}");
    let file_bytes = std::fs::metadata(demo.join("demo.vtk")).unwrap().len();
    for (r, size) in rows.iter().zip([40.0, 64.0]) {
        assert_eq!(r[0], "demo");
        let v: Vec<f64> = r[1..].iter().map(|x| x.parse().unwrap()).collect();
        assert!(v.iter().all(|x| x.is_finite() && *x >= 0.0), "{r:?}");
        assert!(v[0] > 2000.0 && v[0] < 8000.0, "cells {r:?}");
        assert_eq!(v[1], size);
        assert_eq!(v[3], file_bytes as f64);
        assert!(v[4] > 0.0, "segments {r:?}");
        // ns a cell and a segment: the phase time over the counts (the
        // CSV rounds times to 1 us and these to 0.01 ns).
        assert!(
            (v[9] - v[6] * 1e9 / v[0]).abs() <= 0.011 + 500.0 / v[0],
            "{r:?}"
        );
        assert!(
            (v[10] - v[7] * 1e9 / v[4]).abs() <= 0.011 + 500.0 / v[4],
            "{r:?}"
        );
        assert!((v[13] - v[12] / v[0]).abs() < 0.01, "B a tet {r:?}");
        assert!(v[14] > 5.0 && v[15] > 0.0, "mesh and frame bytes {r:?}");
    }
    assert!(out.join("render-demo-64.png").is_file());
}

#[test]
fn scaling_scenes_without_scaling_is_refused() {
    let o = pvrsim()
        .args(["bench", "--scaling-scenes", "x.toml"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--scaling-scenes") && err.contains("--scaling"),
        "{err}"
    );
}

#[test]
fn a_missing_scene_is_named_before_any_render() {
    let dir = tempfile::tempdir().unwrap();
    let o = pvrsim()
        .args(["bench", "--scaling", "--scaling-scenes", "no-such.toml"])
        .arg("--scaling-out")
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no-such.toml"), "{err}");
}

#[test]
fn two_scenes_of_one_name_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let demo = dir.path().join("d");
    let o = pvrsim()
        .args(["demo", "--cells", "2000", "--nodes", "0", "--out-dir"])
        .arg(&demo)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let other = dir.path().join("e");
    std::fs::create_dir(&other).unwrap();
    let text = std::fs::read_to_string(demo.join("demo.toml")).unwrap();
    std::fs::write(
        other.join("demo.toml"),
        text.replace("\"demo.vtk\"", "\"../d/demo.vtk\""),
    )
    .unwrap();
    let scenes = format!(
        "{},{}",
        demo.join("demo.toml").display(),
        other.join("demo.toml").display()
    );
    let o = pvrsim()
        .args(["bench", "--scaling", "--scaling-scenes", &scenes])
        .arg("--scaling-out")
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("distinct file names"), "{err}");
}
