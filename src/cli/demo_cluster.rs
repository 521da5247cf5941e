//! The cluster part of `pvrsim demo`: the ERT scene (`demo-ert.toml`,
//! [`crate::data::demo_ert`]) on the simulated cluster with `pvrsim
//! cluster`'s defaults at `--ert 0.9 --share --dlb` (virtual clock, `gbe`,
//! `pentium4`), the oracle's share of skippable cells, and Base (ERT,
//! sharing and DLB off) beside ERT+DLB+SHARE.

use std::path::Path;

use anyhow::Context;
use clap::Parser;

use super::cluster::ClusterArgs;
use crate::cluster::{self, timeline};
use crate::render::cell::{self, CellOptions};
use crate::render::RenderInput;

/// `pvrsim cluster`'s options, parsed from a command line (so the demo runs
/// exactly what the command's defaults are).
#[derive(Debug, Parser)]
struct ClusterLine {
    #[command(flatten)]
    args: ClusterArgs,
}

/// Runs the ERT scene at `scene_path` (already loaded as `input`) on
/// `nodes` nodes and prints the comparison; writes `cluster.png`,
/// `timeline.png` and `cluster-report.json` into `out_dir`.
pub fn run_cluster(
    out_dir: &Path,
    scene_path: &Path,
    input: &RenderInput,
    nodes: usize,
    threads: usize,
) -> anyhow::Result<()> {
    let thr = 0.9f32;
    let o = super::with_threads(threads, || {
        cell::ert::oracle::oracle(input, &CellOptions::default(), thr)
    })?;
    println!(
        "{}: a perfect ERT test at {thr} could skip {} of {} cells ({:.1} %; the oracle, pvrsim render --oracle)",
        scene_path.display(),
        o.cells_skippable,
        input.mesh.tets.len(),
        100.0 * o.cells_skippable as f64 / input.mesh.tets.len().max(1) as f64
    );
    let line = ClusterLine::try_parse_from([
        "cluster".to_string(),
        scene_path.display().to_string(),
        "--nodes".into(),
        nodes.to_string(),
        "--ert".into(),
        thr.to_string(),
        "--share".into(),
        "--dlb".into(),
    ])?;
    let job = crate::job::Valid::new(&line.args)?;
    let cfg = super::cluster::config(&job)?;
    let t = std::time::Instant::now();
    let out = super::with_threads(threads, || cluster::run(input, &cfg))??;
    let host_s = t.elapsed().as_secs_f64();
    let png = out_dir.join("cluster.png");
    out.image.save_png(&png)?;
    let tl = out_dir.join("timeline.png");
    timeline::draw(&out.trace, out.report.n_nodes, &tl)?;
    let rep = out_dir.join("cluster-report.json");
    std::fs::write(&rep, serde_json::to_string_pretty(&out.report)?)
        .with_context(|| format!("cannot write {}", rep.display()))?;
    let r = &out.report;
    println!(
        "simulated cluster: {} nodes + manager, ERT {}, gbe, pentium4 (virtual clock, {:.2} s on this machine); data {}",
        r.n_nodes,
        r.ert_threshold,
        host_s,
        if r.replication.is_some() { "replicated" } else { "partitioned" }
    );
    let base = r
        .base_tsc_max_s
        .context("the cluster run did not measure Base")?;
    println!("  {:<34} {:>10} {:>15}", "", "Base", "ERT+DLB+SHARE");
    println!(
        "  {:<34} {:>10.3} {:>15.3}",
        "slowest node's Tsc (s)", base, r.tsc_max_s
    );
    println!(
        "  {:<34} {:>10} {:>15}",
        "cells skipped by ERT", 0, r.cells_skipped_ert
    );
    println!(
        "  {:<34} {:>10.2} {:>15.2}",
        "speed-up over Base (Base Tsc / Tsc)",
        1.0,
        base / r.tsc_max_s.max(1e-12)
    );
    println!(
        "  ERT+DLB+SHARE: frame {:.3} s (phase 1 {:.3} s, compositing {:.3} s), imbalance {:.1} %, {} cells moved by DLB and help, share efficiency {}",
        r.frame_s,
        r.phase1_s,
        r.composite_s,
        100.0 * r.imbalance,
        r.cells_moved,
        r.share_efficiency
            .map_or("n/a".to_string(), |e| format!("{e:.3}"))
    );
    println!(
        "wrote {}, {} and {}",
        png.display(),
        tl.display(),
        rep.display()
    );
    Ok(())
}
