//! Partitioned data read where it is used: a scene whose data is a `.pvtu`
//! on worker processes, each worker reading its own pieces (VTK 9.7.2's own
//! pieces of the small aorta, `tests/data/pieces/`, boundary vertices
//! duplicated across pieces). The image equals the single-process render of
//! the union bit for bit; bad pieces fail with the piece named.

use std::path::Path;

mod cli_support;
use cli_support::{copy_vtk_pieces, data, pvrsim};

/// VTK's `enc` (raw, zlib) pieces as `a.pvtu` with view B's scene
/// `scene.toml`, then `edit`ed.
fn pieces_scene(enc: &str, edit: impl FnOnce(&Path)) -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    copy_vtk_pieces(enc, d.path());
    let scene = std::fs::read_to_string(data("aorta-small-view-b.toml")).unwrap();
    let scene = scene.replace("path  = \"aorta-small.vtk\"", "path  = \"a.pvtu\"");
    assert!(scene.contains("a.pvtu"));
    std::fs::write(d.path().join("scene.toml"), scene).unwrap();
    edit(d.path());
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `pvrsim render --canonical --ert 1` of the scene: the PNG's bytes.
fn single(d: &Path) -> Vec<u8> {
    let o = d.join("single.png");
    let (ok, err) = pvrsim(&[
        "render",
        s(&d.join("scene.toml")),
        "-o",
        s(&o),
        "--canonical",
        "--ert",
        "1",
    ]);
    assert!(ok, "{err}");
    std::fs::read(o).unwrap()
}

/// `pvrsim cluster --transport processes --canonical --ert 1` with `extra`
/// options: (success, stderr, PNG bytes, report JSON).
fn cluster(d: &Path, nodes: &str, extra: &[&str]) -> (bool, String, Vec<u8>, String) {
    let o = d.join(format!("cluster-{nodes}.png"));
    let r = d.join(format!("cluster-{nodes}.json"));
    let scene = d.join("scene.toml");
    let mut args = vec![
        "cluster",
        s(&scene),
        "--nodes",
        nodes,
        "--transport",
        "processes",
        "--canonical",
        "--ert",
        "1",
        "-o",
        s(&o),
        "--report",
        s(&r),
    ];
    args.extend_from_slice(extra);
    let (ok, err) = pvrsim(&args);
    let png = std::fs::read(&o).unwrap_or_default();
    let json = std::fs::read_to_string(&r).unwrap_or_default();
    (ok, err, png, json)
}

#[test]
fn workers_reading_their_pieces_render_the_union_bit_for_bit() {
    for enc in ["zlib", "raw"] {
        let d = pieces_scene(enc, |_| {});
        let want = single(d.path());
        // 4 nodes: a piece each; 3 nodes: runs of pieces; 6 nodes: two
        // pieces split in two (each of their nodes reads the piece and keeps
        // its part), and DLB moves cells with their vertices, duplicated
        // boundary vertices and all.
        for (nodes, extra) in [("4", &[][..]), ("3", &[][..]), ("6", &["--dlb"][..])] {
            let (ok, err, png, json) = cluster(d.path(), nodes, extra);
            assert!(ok, "{enc}, {nodes} nodes: {err}");
            assert!(png == want, "{enc}, {nodes} nodes: the image differs");
            assert!(json.contains("\"placement\": \"pieces\""), "{json}");
            // 20169 tetrahedra in the four pieces, none sent.
            assert!(json.contains("\"cells_total\": 20169"), "{json}");
        }
    }
}

#[test]
fn explicit_placement_reads_the_mesh_in_the_coordinator() {
    let d = pieces_scene("zlib", |_| {});
    let want = single(d.path());
    let (ok, err, png, json) = cluster(d.path(), "2", &["--placement", "rcb"]);
    assert!(ok, "{err}");
    assert!(png == want);
    assert!(json.contains("\"placement\": \"rcb\""), "{json}");
}

/// A bad piece fails the cluster run with the piece named and a non-zero
/// exit, as the worker that reads it (or the coordinator) sees it.
fn fails(d: &Path, expect: &[&str]) {
    let (ok, err, _, _) = cluster(d, "4", &[]);
    assert!(!ok, "a bad piece rendered");
    for e in expect {
        assert!(err.contains(e), "no {e:?} in: {err}");
    }
}

#[test]
fn bad_pieces_are_named() {
    // Missing piece: the coordinator reads the pieces' vertices first.
    let d = pieces_scene("zlib", |d| {
        std::fs::remove_file(d.join("aorta-small-zlib_2.vtu")).unwrap()
    });
    fails(d.path(), &["<Piece> 2", "aorta-small-zlib_2.vtu"]);
    // Truncated piece (its cells cut off): the coordinator's read of the
    // vertices may pass; the worker's read of the cells must not.
    let d = pieces_scene("raw", |d| {
        let p = d.join("aorta-small-raw_1.vtu");
        let b = std::fs::read(&p).unwrap();
        std::fs::write(&p, &b[..b.len() - 5000]).unwrap();
    });
    fails(d.path(), &["<Piece> 1", "aorta-small-raw_1.vtu"]);
    // A piece outside the .pvtu's folder.
    let d = pieces_scene("zlib", |d| {
        let p = d.join("a.pvtu");
        let t = std::fs::read_to_string(&p).unwrap();
        std::fs::write(
            &p,
            t.replace("\"aorta-small-zlib_3.vtu\"", "\"../elsewhere.vtu\""),
        )
        .unwrap();
    });
    fails(d.path(), &["<Piece> 3", "../elsewhere.vtu"]);
    // A field the pieces lack.
    let d = pieces_scene("zlib", |d| {
        let p = d.join("scene.toml");
        let t = std::fs::read_to_string(&p).unwrap();
        std::fs::write(&p, t.replace("field = \"speed\"", "field = \"nope\"")).unwrap();
    });
    fails(d.path(), &["nope", "speed"]);
}

#[test]
fn options_that_need_the_cells_here_are_refused() {
    let d = pieces_scene("zlib", |d| {
        std::fs::write(d.join("series.toml"), "[[frame]]\nturn = 10\n").unwrap();
    });
    let series = d.path().join("series.toml");
    let (ok, err, _, _) = cluster(d.path(), "2", &["--series", s(&series)]);
    assert!(!ok && err.contains("--placement rcb"), "{err}");
    let scene = d.path().join("scene.toml");
    let (ok, err) = pvrsim(&[
        "cluster",
        s(&scene),
        "--nodes",
        "2",
        "--transport",
        "processes",
        "--sharing",
        "overlap",
        "--ert",
        "0.9",
    ]);
    assert!(!ok && err.contains("--sharing overlap"), "{err}");
}

#[test]
fn an_orbit_runs_on_the_same_workers() {
    let d = pieces_scene("zlib", |_| {});
    let o = d.path().join("f-%d.png");
    let r = d.path().join("series.json");
    let (ok, err) = pvrsim(&[
        "cluster",
        s(&d.path().join("scene.toml")),
        "--nodes",
        "2",
        "--transport",
        "processes",
        "--frames",
        "3",
        "--turn",
        "20",
        "-o",
        s(&o),
        "--report",
        s(&r),
    ]);
    assert!(ok, "{err}");
    for f in 0..3 {
        assert!(d.path().join(format!("f-{f}.png")).exists());
    }
    let json = std::fs::read_to_string(r).unwrap();
    assert!(json.contains("\"series\""), "{json}");
}

#[test]
fn a_lost_workers_pieces_are_read_by_the_survivors() {
    let d = pieces_scene("zlib", |_| {});
    let want = single(d.path());
    for hook in ["2:--test-kill-at-setup", "2:--test-kill-after-chunks 2"] {
        let (ok, err, png, json) = cluster(
            d.path(),
            "4",
            &[
                "--on-failure",
                "reassign",
                "--heartbeat-timeout",
                "2",
                "--test-worker-hook",
                hook,
            ],
        );
        assert!(ok, "{hook}: {err}");
        assert!(png == want, "{hook}: the image differs");
        assert!(json.contains("\"reassigned\""), "{hook}: {json}");
        assert!(json.contains("\"n_nodes\": 3"), "{hook}: {json}");
    }
}

#[test]
fn the_pieces_place_the_nodes_on_every_transport() {
    let d = pieces_scene("zlib", |_| {});
    let want = single(d.path());
    let scene = d.path().join("scene.toml");
    // The simulated cluster and threads: the union in this process, placed
    // by the pieces by default; the same image as the workers' and the
    // single-process render's, and the same cells per node. On 6 nodes the
    // 4 pieces are split (every node works), alike in this process and by
    // the workers reading their pieces.
    for nodes in ["3", "6"] {
        let mut cells_per_node = Vec::new();
        for transport in [None, Some("threads"), Some("processes")] {
            let o = d.path().join("t.png");
            let r = d.path().join("t.json");
            let mut args = vec![
                "cluster",
                s(&scene),
                "--nodes",
                nodes,
                "--canonical",
                "--ert",
                "1",
                "--no-baselines",
                "-o",
                s(&o),
                "--report",
                s(&r),
            ];
            if let Some(t) = transport {
                args.extend(["--transport", t]);
            }
            let (ok, err) = pvrsim(&args);
            assert!(ok, "{transport:?}: {err}");
            assert!(
                std::fs::read(&o).unwrap() == want,
                "{nodes} nodes, {transport:?}: the image differs"
            );
            let json: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&r).unwrap()).unwrap();
            assert_eq!(json["placement"], "pieces", "{transport:?}");
            let per_node: Vec<u64> = json["nodes"]
                .as_array()
                .unwrap()
                .iter()
                .map(|n| n["cells_initial"].as_u64().unwrap())
                .collect();
            assert!(
                per_node.iter().all(|&c| c > 0),
                "{nodes} nodes, {transport:?}: a node started empty: {per_node:?}"
            );
            assert_eq!(per_node.iter().sum::<u64>(), 20169);
            if transport == Some("processes") {
                let split = json["pieces"]["shares"].as_array().map(|a| a.len());
                assert_eq!(
                    split,
                    (nodes == "6").then_some(6),
                    "the report's shares: {}",
                    json["pieces"]
                );
            }
            cells_per_node.push(per_node);
        }
        assert!(
            cells_per_node.windows(2).all(|w| w[0] == w[1]),
            "{nodes} nodes: {cells_per_node:?}"
        );
    }
    // One file has no pieces.
    let (ok, err) = pvrsim(&[
        "cluster",
        s(&data("aorta-small-view-b.toml")),
        "--nodes",
        "2",
        "--placement",
        "pieces",
    ]);
    assert!(
        !ok && err.contains("--placement pieces") && err.contains(".pvtu"),
        "{err}"
    );
}
