//! Memory per node in the cluster report: worker processes send their peak
//! resident memory with their result (`nodes[i].peak_rss_bytes`), the
//! coordinator states its own (`coordinator_peak_rss_bytes`); the virtual
//! clock states the modelled bytes of each node's part and lists
//! (`nodes[i].modelled_bytes`) instead.

mod transport_support;
use transport_support::*;

#[test]
fn worker_processes_report_their_peak_resident_memory() {
    let scene = data("aorta-small-view-b.toml");
    let (input, cfg) = config(&scene, &["--nodes", "2", "--canonical", "--ert", "1"]);
    let out = on_processes(&input, &cfg);
    let r = &out.report;
    let c = r
        .coordinator_peak_rss_bytes
        .expect("coordinator's peak RSS");
    // A process that loaded a mesh and ran a frame holds at least 1 MB and
    // (this small mesh) far less than 4 GB.
    assert!((1 << 20..4 << 30).contains(&c), "coordinator {c} B");
    assert_eq!(r.nodes.len(), 2);
    for x in &r.nodes {
        let p = x.peak_rss_bytes.expect("worker's peak RSS");
        assert!((1 << 20..4 << 30).contains(&p), "node {}: {p} B", x.rank);
        assert_eq!(x.modelled_bytes, None, "node {}", x.rank);
    }
    let json = serde_json::to_value(r).unwrap();
    assert!(json["nodes"][1]["peak_rss_bytes"].as_u64().unwrap() > 0);
    assert!(json["coordinator_peak_rss_bytes"].as_u64().unwrap() > 0);
    let text = pvrsim::cluster::report::summary(r);
    assert!(
        text.contains("peak resident memory (MB, measured): coordinator"),
        "{text}"
    );
}

#[test]
fn virtual_clock_reports_modelled_memory_per_node() {
    let scene = data("aorta-small-view-b.toml");
    let (input, cfg) = config(&scene, &["--nodes", "3", "--canonical", "--ert", "1"]);
    let out = pvrsim::cluster::run(&input, &cfg).unwrap();
    let r = &out.report;
    assert_eq!(r.coordinator_peak_rss_bytes, None);
    let m = &input.mesh;
    let mut sum_cells_bytes = 0;
    for x in &r.nodes {
        assert_eq!(x.peak_rss_bytes, None);
        let b = x.modelled_bytes.expect("modelled bytes");
        // At least its cells (16 B) and their list entries (24 B); its
        // vertices come on top.
        let floor = x.cells_initial * 16 + x.segments_stored * 24;
        assert!(b > floor, "node {}: {b} <= {floor}", x.rank);
        // At most every vertex of the mesh on top.
        assert!(b <= floor + m.points.len() as u64 * 28, "node {}", x.rank);
        sum_cells_bytes += x.cells_initial * 16;
    }
    assert_eq!(sum_cells_bytes, m.tets.len() as u64 * 16);
    let text = pvrsim::cluster::report::summary(r);
    assert!(text.contains("memory per node (MB, modelled"), "{text}");
}
