//! `pvrsim bench --scaling --scaling-scenes A.toml,B.toml`: the scaling
//! benchmark on meshes the user brings (e.g. `bench/meshes/make.sh`'s gmsh
//! parts and the permuted demo) instead of the generated vessels. Each scene
//! is rendered by a child `pvrsim render` per image size, one thread, exact,
//! ERT off, reaped with `wait4` for its own peak RSS; the rows go to
//! `scaling-scenes.csv` with the per-cell and per-segment costs.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context};

use super::scaling::{read_stats, run_measured, stat};

/// One scene rendered at one size (a row of `scaling-scenes.csv`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct SceneRow {
    /// The scene file's stem (e.g. `part-18000000`).
    pub mesh: String,
    /// Tetrahedra in the mesh (`cells_total`).
    pub cells: u64,
    /// Image width = height, pixels.
    pub image: u32,
    /// Render threads.
    pub threads: usize,
    /// Bytes of the mesh file.
    pub file_bytes: u64,
    /// Segments the projection generated (`segments_generated`).
    pub segments: u64,
    /// Load phase, s.
    pub load_s: f64,
    /// Projection phase, s.
    pub project_s: f64,
    /// Scan phase, s.
    pub scan_s: f64,
    /// Compositing phase, s.
    pub composite_s: f64,
    /// `project_s` a cell of the mesh (culled ones included, as in issue 53), ns.
    pub project_ns_per_cell: f64,
    /// `scan_s` a generated segment, ns.
    pub scan_ns_per_segment: f64,
    /// Wall time of the render child process.
    pub process_s: f64,
    /// Peak RSS of the render child, bytes (`wait4` ru_maxrss).
    pub peak_rss_bytes: u64,
    /// `peak_rss_bytes / cells`.
    pub bytes_per_tet: f64,
    /// The mesh's bytes in memory / cells (`mesh_bytes`).
    pub mesh_bytes_per_tet: f64,
    /// The frame's own bytes / cells (`frame_bytes`).
    pub frame_bytes_per_tet: f64,
}

/// The CSV header, in column order of [`SceneRow`].
pub const CSV_HEADER: &str = "mesh,cells,image,threads,file_bytes,segments,load_s,project_s,scan_s,composite_s,project_ns_per_cell,scan_ns_per_segment,process_s,peak_rss_bytes,bytes_per_tet,mesh_bytes_per_tet,frame_bytes_per_tet";

impl SceneRow {
    fn csv(&self) -> String {
        format!(
            "{},{},{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.2},{:.2},{:.6},{},{:.2},{:.2},{:.2}",
            self.mesh,
            self.cells,
            self.image,
            self.threads,
            self.file_bytes,
            self.segments,
            self.load_s,
            self.project_s,
            self.scan_s,
            self.composite_s,
            self.project_ns_per_cell,
            self.scan_ns_per_segment,
            self.process_s,
            self.peak_rss_bytes,
            self.bytes_per_tet,
            self.mesh_bytes_per_tet,
            self.frame_bytes_per_tet
        )
    }
}

/// Renders each scene at each size; writes `scaling-scenes.csv` into `out`.
pub fn run(
    scenes: &[PathBuf],
    sizes: &[u32],
    threads: usize,
    out: &Path,
) -> anyhow::Result<Vec<SceneRow>> {
    if sizes.is_empty() || sizes.contains(&0) || threads == 0 {
        bail!("--scaling-sizes needs sizes > 0 and --scaling-threads must be > 0");
    }
    // Check every scene before the first (long) render.
    let mut meshes = Vec::new();
    for s in scenes {
        let scene = crate::scene::Scene::load(s)
            .with_context(|| format!("--scaling-scenes {}", s.display()))?;
        let bytes = std::fs::metadata(&scene.data.path)
            .with_context(|| format!("{}: data {}", s.display(), scene.data.path.display()))?
            .len();
        let stem = s
            .file_stem()
            .map(|x| x.to_string_lossy().into_owned())
            .unwrap_or_default();
        if stem.contains(',') {
            bail!(
                "--scaling-scenes {}: the CSV cannot hold a comma in the name",
                s.display()
            );
        }
        if meshes.iter().any(|(_, m, _)| *m == stem) {
            bail!(
                "--scaling-scenes {}: another scene is also named `{stem}` (its rows and files would mix): give them distinct file names",
                s.display()
            );
        }
        meshes.push((s, stem, bytes));
    }
    let exe = std::env::current_exe().context("cannot find the pvrsim executable")?;
    std::fs::create_dir_all(out).with_context(|| format!("--scaling-out {}", out.display()))?;
    let mut rows = Vec::new();
    for (scene, stem, file_bytes) in meshes {
        for &s in sizes {
            let stats = out.join(format!("stats-{stem}-{s}.json"));
            let png = out.join(format!("render-{stem}-{s}.png"));
            let mut cmd = Command::new(&exe);
            cmd.arg("render")
                .arg(scene)
                .arg("-o")
                .arg(&png)
                .args(["--threads", &threads.to_string(), "--ert", "1"])
                .args(["--width", &s.to_string(), "--height", &s.to_string()])
                .arg("--stats")
                .arg(&stats);
            let (process_s, rss) = run_measured(cmd, &format!("pvrsim render {stem} ({s}^2)"))?;
            let v = read_stats(&stats)?;
            let cells = stat(&v, "cells_total", &stats)? as u64;
            let segments = stat(&v, "segments_generated", &stats)? as u64;
            let project_s = stat(&v, "time_project_s", &stats)?;
            let scan_s = stat(&v, "time_scan_s", &stats)?;
            let per = |b: f64| b / cells.max(1) as f64;
            let row = SceneRow {
                mesh: stem.clone(),
                cells,
                image: s,
                threads,
                file_bytes,
                segments,
                load_s: stat(&v, "time_load_s", &stats)?,
                project_s,
                scan_s,
                composite_s: stat(&v, "time_composite_s", &stats)?,
                project_ns_per_cell: project_s * 1e9 / cells.max(1) as f64,
                scan_ns_per_segment: scan_s * 1e9 / segments.max(1) as f64,
                process_s,
                peak_rss_bytes: rss,
                bytes_per_tet: per(rss as f64),
                mesh_bytes_per_tet: per(stat(&v, "mesh_bytes", &stats)?),
                frame_bytes_per_tet: per(stat(&v, "frame_bytes", &stats)?),
            };
            eprintln!(
                "scaling: {stem} ({} cells, {s}^2): load {:.3} s, project {:.3} s ({:.1} ns a cell), scan {:.3} s ({:.1} ns a segment, {} segments), peak RSS {:.1} B a tet (mesh {:.1}, frame {:.1})",
                row.cells, row.load_s, row.project_s, row.project_ns_per_cell, row.scan_s,
                row.scan_ns_per_segment, row.segments, row.bytes_per_tet,
                row.mesh_bytes_per_tet, row.frame_bytes_per_tet
            );
            rows.push(row);
        }
    }
    let csv = out.join("scaling-scenes.csv");
    let mut text = String::from(CSV_HEADER);
    text.push('\n');
    for r in &rows {
        text.push_str(&r.csv());
        text.push('\n');
    }
    std::fs::write(&csv, text).with_context(|| format!("{}", csv.display()))?;
    println!("wrote {}", csv.display());
    Ok(rows)
}
